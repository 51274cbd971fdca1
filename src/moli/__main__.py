"""Run the moli command: ``python -m moli``."""

from .cli import main

main()
