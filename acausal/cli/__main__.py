"""``python -m acausal.cli``: the ``acausal`` command."""
from .commands import main

raise SystemExit(main())
