"""The steps of identify(): preparation (the call's options, the hold-out, the records the search
runs on), the order choice, and the finishing phases (refinement, long-record re-estimate,
direct method, covariance, noise model), with what Ctrl-C after the path cuts.
"""

__all__: list[str] = []
