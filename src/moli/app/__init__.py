"""At the edge: the command line, HTML reports and figures (needs the ``cli`` extra)."""

__all__: list[str] = []
