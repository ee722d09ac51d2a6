"""``python -m vehicle_observers.bench``: the speed and accuracy benchmark (``make bench``)."""

from vehicle_observers.bench.suite import main

if __name__ == "__main__":
    raise SystemExit(main())
