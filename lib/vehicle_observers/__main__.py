"""``python -m vehicle_observers``: the command line (see :mod:`vehicle_observers.cli.main`)."""

from vehicle_observers.cli.main import main

if __name__ == "__main__":
    raise SystemExit(main())
