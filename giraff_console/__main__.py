"""`python -m giraff_console`."""

from giraff_console.launch import main

raise SystemExit(main())
