"""Truth plants of campaigns, registered like estimators (open to plug-ins).

A plant is ``simulate(car, manoeuvre, rate) -> dict`` of noise-free channels (each (N,), SI
units): ``t`` [s], ``vx``, ``delta`` (road-wheel angle), ``r`` (yaw rate), ``ay`` (what a
noise-free accelerometer reads), ``vy``, ``Ff``, ``Fr``, and optionally ``extra`` = a dict with
``yL``, ``psiL``, ``rho`` (vision and curvature channels), sampled at ``native_rate`` [Hz], or
at ``rate`` when ``native_rate`` is ``None`` (a plant simulated at the log's sample rate).
``car`` is a name of :func:`cars_of`; ``manoeuvre`` a
:class:`vehicle_observers.data.plant.Manoeuvre` (reference steering and speed on a 100 Hz
grid). The built-in plants (``multibody``, ``yaw-drift``, ``lpv``) are registered by
:mod:`vehicle_observers.campaign.truths`; a plug-in module (a campaign's ``plugins``) calls
:func:`register_plant` to add one, which a spec then names as ``"name:car"`` in
``truth.plants``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

from vehicle_observers.core.errors import RegistryError

#: log columns every plant's logs have beyond the four required ones
BASE_PLANT_COLUMNS = ("ay_mps2", "vy_mps", "Ff_N", "Fr_N", "ax_mps2")
#: CommonRoad cars of the multi-body plant (:func:`vehicle_observers.data.plant.plant_parameters`)
COMMONROAD_CARS = {"ford_escort": 1, "bmw_320i": 2, "vw_vanagon": 3}


@dataclass(frozen=True)
class PlantSpec:
    """One registered truth plant (module docstring). ``columns``: the log columns its logs
    give (``extra`` channels: ``yL_m``, ``psiL_rad``, ``rho_1pm``); ``cars``: the car names it
    accepts (``None``: the CommonRoad cars and the shipped vehicle files); ``origin``: the
    registering module."""

    name: str
    simulate: Callable[..., dict]
    native_rate: float | None
    columns: tuple = BASE_PLANT_COLUMNS
    cars: tuple | None = None
    description: str = ""
    origin: str = ""


_PLANTS: dict[str, PlantSpec] = {}


def register_plant(name: str, simulate: Callable, *, native_rate: float | None,
                   extra_columns=(), cars=None, description: str = "",
                   replace: bool = False) -> PlantSpec:
    """Register a truth plant (module docstring). ``extra_columns``: log columns beyond
    :data:`BASE_PLANT_COLUMNS` its logs give (``yL_m``, ``psiL_rad``, ``rho_1pm``)."""
    if not name or ":" in name or any(c.isspace() for c in name):
        raise RegistryError(f"plant name {name!r}: a non-empty word without ':' or spaces")
    if native_rate is not None and not native_rate > 0:
        raise RegistryError(f"plant {name!r}: native_rate must be > 0 Hz or None")
    spec = PlantSpec(name, simulate, None if native_rate is None else float(native_rate),
                     BASE_PLANT_COLUMNS + tuple(extra_columns),
                     None if cars is None else tuple(cars), description,
                     getattr(simulate, "__module__", ""))
    old = _PLANTS.get(name)
    if old is not None and not replace and old.origin != spec.origin:
        raise RegistryError(f"plant {name!r} is registered twice ({old.origin} and "
                            f"{spec.origin}); pass replace=True to override")
    _PLANTS[name] = spec
    return spec


def plants() -> dict[str, PlantSpec]:
    """The registered plants (the built-in ones are registered by
    :mod:`vehicle_observers.campaign.truths`, imported with the package)."""
    return dict(_PLANTS)


def get_plant(name: str) -> PlantSpec:
    p = plants()
    if name not in p:
        raise RegistryError(f"unknown plant {name!r} (registered: {', '.join(p)})")
    return p[name]


def cars_of(plant: PlantSpec) -> tuple[str, ...]:
    """The car names ``plant`` accepts."""
    if plant.cars is not None:
        return plant.cars
    from vehicle_observers.models.vehicle import builtin_vehicles

    return tuple(COMMONROAD_CARS) + tuple(sorted(builtin_vehicles()))


def unregister_plant(name: str):
    """Remove ``name`` (tests and interactive sessions)."""
    _PLANTS.pop(name, None)
