"""Run the moli command: ``python -m moli``."""

from .app.cli import main

if __name__ == "__main__":
    main()
