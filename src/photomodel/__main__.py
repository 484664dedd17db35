"""``python -m photomodel`` runs the command line."""

from photomodel.cli import main

raise SystemExit(main())
