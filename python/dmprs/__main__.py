"""``python -m dmprs ...`` is the ``dmprs`` command."""

from dmprs.cli import main

main(prog_name="dmprs")
