"""Filter tuning (docs/method.md §5, §9-§11): the criterion J of a filter candidate, the
barycenter search, the per-output filter cutoffs.
"""

__all__: list[str] = []
