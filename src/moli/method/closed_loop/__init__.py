"""Closed-loop records (docs/closed_loop.md): which loop method a record calls for, and the
two-stage method's projection of the inputs on the references.
"""

__all__: list[str] = []
