from optroute.cli import main

raise SystemExit(main())
