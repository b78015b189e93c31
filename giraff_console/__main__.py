"""`python -m giraff_console`."""

from giraff_console.cli import main

raise SystemExit(main())
