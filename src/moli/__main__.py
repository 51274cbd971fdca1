"""Run the moli command: ``python -m moli``."""

from .app.console import main

if __name__ == "__main__":
    main()
