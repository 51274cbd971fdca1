"""The structure search (docs/method.md §5, §15): the greedy path over the lists of indices, and
the search on a window of a long record.
"""

__all__: list[str] = []
