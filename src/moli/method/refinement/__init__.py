"""Refinement (docs/method.md §12): the observer-form parameters, the output-error problem and
its Jacobian, Levenberg-Marquardt, the memo of refined path steps, and the direct method's
prediction-error estimate.
"""

__all__: list[str] = []
