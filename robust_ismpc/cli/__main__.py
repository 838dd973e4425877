"""``python -m robust_ismpc.cli``: the ``ismpc`` command."""

from . import main

raise SystemExit(main())
