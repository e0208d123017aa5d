"""``python -m kinsync``: same as the ``kinsync`` program."""

from kinsync.cli import main

main()
