"""``python -m sklearn_meshph``: the command line's main job (see :mod:`.cli`)."""

from .cli import main

if __name__ == "__main__":
    raise SystemExit(main())
