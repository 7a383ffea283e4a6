"""``python -m jaxwalk``: the same as the ``jaxwalk`` command."""

from jaxwalk.cli import main

if __name__ == "__main__":
    raise SystemExit(main())
