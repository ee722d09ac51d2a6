"""``python -m vehicle_observers``: the command line (see :mod:`vehicle_observers.cli.main`)."""

from vehicle_observers.cli.main import console

if __name__ == "__main__":
    console()
