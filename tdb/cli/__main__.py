"""``python -m tdb.cli``: the same as the ``tdb`` command."""

from tdb.cli import main

main()
