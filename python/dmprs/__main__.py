"""``python -m dmprs demo [--out DIR]``: the main job until the CLI issue adds ``dmprs``."""

import sys

from dmprs import demo

if __name__ == "__main__":
    args = sys.argv[1:]
    if args[:1] == ["demo"]:
        args = args[1:]
    sys.exit(demo.main(args))
