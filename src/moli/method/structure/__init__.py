"""What a MOLI model is (docs/method.md §1-§3): lists of observability indices, the filter α and
its divisors α_j, and which samples of each segment are regression rows.
"""

__all__: list[str] = []
