"""Closed-loop records (docs/closed_loop.md): the two-stage method's projection of the inputs on
the references.
"""

__all__: list[str] = []
