"""identify()'s records before the search (short segments out, inputs delayed), and what Ctrl-C
after the path cuts.
"""

__all__: list[str] = []
