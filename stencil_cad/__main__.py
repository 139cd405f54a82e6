from stencil_cad.cli import main

raise SystemExit(main())
