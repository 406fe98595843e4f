from cotsfleet.cli import main

raise SystemExit(main())
