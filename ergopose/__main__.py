from ergopose.cli import main

raise SystemExit(main())
