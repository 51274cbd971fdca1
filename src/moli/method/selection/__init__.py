"""Which model is returned (docs/method.md §5, §12): the paired test, the order rules, the
candidates and policy of the guarded refinement, and the checks of the selection.
"""

__all__: list[str] = []
