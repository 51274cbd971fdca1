"""Run the moli command: ``python -m moli``."""

from .cli import main

if __name__ == "__main__":
    main()
