"""One list's least squares (docs/method.md §3-§4, §8): filtered regressors in row blocks, the
factors every list of one filter search shares, regularization, the sandwich covariance kernel
and the realization of (A, B, C, D).
"""

__all__: list[str] = []
