from mane.app.cli import main

raise SystemExit(main())
