"""Library inputs are converted once where they enter (:mod:`vehicle_observers.core.inputs`).

The same drive given as NumPy arrays, lists, tuples, polars Series or DataFrames (pandas
objects take the same ``to_numpy`` path; pandas is not installed in this environment),
with time in seconds or as ``datetime64`` / ``timedelta64``, gives the same ``DriveLog`` and
the same estimate; a time that goes back or repeats, a NaN, a missing time, text, a wrong
shape or length is refused with the package's error naming the argument, row and column,
whether it enters through ``DriveLog``, the registry's ``estimate`` (also for a log changed
after it was built) or an observer's ``run``. Vehicle constants no car has are refused when
the constants are built."""

from __future__ import annotations

import dataclasses

import numpy as np
import polars as pl
import pytest
from vehicle_observers.core.errors import LogFormatError, ObserverArgumentError
from vehicle_observers.core.protocol import check_data
from vehicle_observers.data.logs import DriveLog
from vehicle_observers.estimation import registry
from vehicle_observers.models.vehicle import load_vehicle

N = 300
T = np.arange(N) * 0.01
COLS = {"t_s": T, "vx_mps": np.full(N, 15.0), "delta_roadwheel_rad": 0.02 * np.sin(T),
        "yaw_rate_radps": 0.1 * np.sin(T), "ay_mps2": 1.5 * np.sin(T)}
ATTR = {"t_s": "t", "vx_mps": "vx", "delta_roadwheel_rad": "delta", "yaw_rate_radps": "yaw_rate",
        "ay_mps2": "ay"}


def _log(conv=lambda a: a, **over):
    cols = {**COLS, **over}
    return DriveLog(**{ATTR[c]: conv(v) for c, v in cols.items()})


FORMS = {"numpy": lambda a: a, "list": lambda a: a.tolist(), "tuple": lambda a: tuple(a.tolist()),
         "polars Series": pl.Series}


@pytest.mark.parametrize("form", list(FORMS))
def test_every_array_form_gives_the_same_log_and_estimate(form):
    """Catches: a log built from lists that passes its checks, then fails with a TypeError
    deep inside an observer (or a polars Series read wrongly)."""
    ref = _log()
    log = _log(FORMS[form])
    for a in ATTR.values():
        v = getattr(log, a)
        assert isinstance(v, np.ndarray) and v.dtype == float
        assert np.array_equal(v, getattr(ref, a))
    veh = load_vehicle("yacine2015")
    e0 = registry.get("ekf").estimate(ref, veh).table()
    e1 = registry.get("ekf").estimate(log, veh).table()
    assert all(np.array_equal(e0[k], e1[k]) for k in e0)


@pytest.mark.parametrize("frame", ["polars", "dict"])
def test_a_dataframe_of_schema_columns_is_a_log(frame):
    """Catches: a polars DataFrame ending in AttributeError / ZeroDivisionError."""
    df = {"polars": pl.DataFrame, "dict": dict}[frame](
        {**COLS, "note_1": np.arange(N, dtype=float)})
    veh = load_vehicle("yacine2015")
    ref = registry.get("ekf").estimate(_log(), veh).table()
    got = registry.get("ekf").estimate(df, veh).table()
    assert all(np.array_equal(ref[k], got[k]) for k in ref)
    log = DriveLog.from_frame(df)
    assert np.array_equal(log.extra["note_1"], np.arange(N))


START = np.datetime64("2026-12-03T10:00:00", "ns")
NS = np.round(T * 1e9).astype(np.int64).astype("timedelta64[ns]")


@pytest.mark.parametrize("make", [
    lambda: START + NS,
    lambda: (START + NS).astype("datetime64[us]"),
    lambda: NS + np.timedelta64(5, "s"),
    lambda: pl.Series(START + NS),
], ids=["datetime64[ns]", "datetime64[us]", "timedelta64", "polars datetime"])
def test_datetime_time_is_seconds_from_the_first_sample(make):
    """Catches: datetime64[ns] taken as seconds (off by 1e9 per second of the epoch)."""
    log = _log(t_s=make())
    assert np.allclose(log.t, T, rtol=0, atol=1e-9)
    t, *_ = check_data(make(), np.zeros((N, 1)), np.zeros((N, 1)), None, 1, 1, 2, "obs")
    assert np.allclose(t, T, rtol=0, atol=1e-9)


def _swap(t):
    t = np.array(t, float)
    t[[100, 101]] = t[[101, 100]]
    return t


BAD_TIME = {
    "two timestamps swapped": (_swap(T), "goes back at row 101"),
    "a repeated timestamp": (np.r_[T[:50], T[49], T[51:]], "repeats at row 50"),
    "a NaN time": (np.r_[T[:7], np.nan, T[8:]], "row 7"),
    "a missing datetime (NaT)": (np.r_[START + NS[:9],
                                       np.datetime64("NaT", "ns"),
                                       START + NS[10:]],
                                 "row 9"),
    "time as text": (np.array([f"{x:.2f}" for x in T]), "numbers"),
    "a (N, 2) time": (np.column_stack([T, T]), "(N,)"),
}


@pytest.mark.parametrize("case", list(BAD_TIME))
def test_bad_time_refused_at_every_entry_naming_the_row(case):
    """Catches: non-monotonic time going through the registry's ekf (a silent wrong
    estimate), or an error that does not say where."""
    t, needle = BAD_TIME[case]
    with pytest.raises(LogFormatError, match="t_s") as e:
        _log(t_s=t)
    assert needle in str(e.value)
    with pytest.raises(ObserverArgumentError) as e:
        check_data(t, np.zeros((N, 1)), np.zeros((N, 1)), None, 1, 1, 2, "SomeObserver")
    assert needle in str(e.value) and "SomeObserver: t" in str(e.value)
    # a log built right, then changed: refused where it enters the registry
    log = _log()
    if np.shape(t) == (N,) and np.asarray(t).dtype.kind == "f":
        log.t = t
        with pytest.raises(LogFormatError) as e:
            registry.get("ekf").estimate(log, load_vehicle("yacine2015"))
        assert needle in str(e.value) and "observer 'ekf'" in str(e.value)


BAD_CHANNEL = {
    "NaN": (np.r_[COLS["vx_mps"][:12], np.nan, COLS["vx_mps"][13:]], "first at row 12"),
    "inf": (np.r_[COLS["vx_mps"][:3], np.inf, COLS["vx_mps"][4:]], "first at row 3"),
    "wrong length": (COLS["vx_mps"][:-1], "has 299 rows"),
    "2-D": (np.column_stack([COLS["vx_mps"]] * 2), "1-D numeric array"),
    "text": (np.array(["15"] * N), "numbers"),
    "dates": (np.full(N, START), "dates"),
}


@pytest.mark.parametrize("case", list(BAD_CHANNEL))
def test_bad_channel_refused_naming_column_and_row(case):
    """Catches: NaN, text or a wrong shape accepted and failing far from its cause."""
    v, needle = BAD_CHANNEL[case]
    with pytest.raises(LogFormatError, match="vx_mps") as e:
        _log(vx_mps=v)
    assert needle in str(e.value)


@pytest.mark.parametrize("arg, value, needle", [
    ("u", np.r_[np.zeros(5), np.nan, np.zeros(N - 6)], "row 5, column 0"),
    ("y", [[0.0, 1.0]] * N, "(N, 1)"),
    ("y", pl.DataFrame({"r": np.zeros(N)}), None),
    ("u", [0.0] * N, None),
])
def test_observer_run_arguments_converted_or_refused(arg, value, needle):
    """Catches: an observer's ``run`` that accepts only NumPy arrays, or refuses without
    naming the argument and row."""
    kw = {"u": np.zeros((N, 1)), "y": np.zeros((N, 1)), arg: value}
    if needle is None:
        t, u, y, _ = check_data(T.tolist(), kw["u"], kw["y"], None, 1, 1, 2, "Obs")
        assert u.shape == y.shape == (N, 1) and u.dtype == y.dtype == float
        return
    with pytest.raises(ObserverArgumentError) as e:
        check_data(T, kw["u"], kw["y"], None, 1, 1, 2, "Obs")
    assert f"Obs: {arg}" in str(e.value) and needle in str(e.value)


@pytest.mark.parametrize("key", ["m", "I_z", "a_f", "a_r", "r_f", "l_s"])
@pytest.mark.parametrize("value", [-1500.0, float("nan"), float("inf"), "1500"])
def test_vehicle_constants_no_car_has_are_named(key, value):
    """Catches: a negative mass reaching the LMI solver and reported as "LMIs infeasible"."""
    p = load_vehicle("yacine2015").params
    with pytest.raises(ObserverArgumentError, match=f"LateralParams.{key} must be"):
        dataclasses.replace(p, **{key: value})


def test_negative_mass_vehicle_never_reaches_the_design():
    """Catches: the interval design run on a vehicle of negative mass."""
    veh = load_vehicle("yacine2015")
    with pytest.raises(ObserverArgumentError, match="LateralParams.m"):
        dataclasses.replace(veh, params=dataclasses.replace(veh.params, m=-veh.params.m))
