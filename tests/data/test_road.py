"""Road profiles: ISO 8608 generator and the Belgian-block sample."""

import numpy as np
import pytest
from vehicle_observers.data import road


def test_iso_class_values():
    """ISO 8608 Table: G_d(n0) geometric means 16, 64, 256, 1024, ... 262144 e-6 m^3."""
    expected = [16, 64, 256, 1024, 4096, 16384, 65536, 262144]
    for c, e in zip("ABCDEFGH", expected, strict=True):
        assert road.iso_gd0(c) == pytest.approx(e * 1e-6)
    assert road.iso_psd(0.2, "C") == pytest.approx(256e-6 / 4)
    with pytest.raises(ValueError, match="class"):
        road.iso_gd0("Z")


@pytest.mark.parametrize("cls", list("ABCD"))
def test_variance_exact(cls):
    rd = road.iso8608_road(cls, 1000.0, seed=3)
    var = road.iso8608_variance(cls, 1000.0)
    assert np.var(rd.left) == pytest.approx(var, rel=1e-9)
    assert np.var(rd.right) == pytest.approx(var, rel=1e-9)


@pytest.mark.parametrize("cls", list("ABCD"))
def test_welch_psd_matches_class(cls):
    """Welch estimate over 0.05-2 cycle/m (41 segments of 2^14 samples on 3 km, Hann,
    50 % overlap): geometric-mean ratio to the class line within 10 % and log-log slope
    -2 within 0.1. Amplitudes are deterministic, so only the phase randomness and the
    window leakage move the estimate."""
    rd = road.iso8608_road(cls, 3000.0, dx=0.01, seed=0)
    n, G = road.welch_psd(rd.left, 0.01, nperseg=2**14)
    band = (n > 0.05) & (n < 2.0)
    ratio = np.exp(np.mean(np.log(G[band] / road.iso_psd(n[band], cls))))
    assert ratio == pytest.approx(1.0, abs=0.10)
    slope = np.polyfit(np.log(n[band]), np.log(G[band]), 1)[0]
    assert slope == pytest.approx(-2.0, abs=0.1)


def test_seeded_and_independent_tracks():
    a = road.iso8608_road("C", 500.0, seed=1)
    b = road.iso8608_road("C", 500.0, seed=1)
    c = road.iso8608_road("C", 500.0, seed=2)
    np.testing.assert_array_equal(a.left, b.left)
    assert not np.allclose(a.left, c.left)
    assert abs(np.corrcoef(a.left, a.right)[0, 1]) < 0.3


def test_belgian_block_loader_and_extension():
    bb = road.load_belgian_block()
    assert len(bb.s) == 1001 and bb.length == pytest.approx(10.0)
    assert abs(bb.left.mean()) < 1e-12
    sl, sr = bb.rms()
    assert 0.021 < sl < 0.025 and 0.021 < sr < 0.025  # PROVENANCE: 22-24 mm detrended
    ext = road.mirror_extend(bb, 95.0)
    assert ext.length >= 95.0
    # mirror extension: no jump larger than the largest step inside the sample
    assert np.abs(np.diff(ext.left)).max() <= np.abs(np.diff(bb.left)).max() + 1e-12
    np.testing.assert_array_equal(ext.left[:1001], bb.left)
    np.testing.assert_allclose(ext.left[1000:2001], bb.left[::-1])


def test_wheel_inputs_rear_delayed_by_wheelbase():
    rd = road.iso8608_road("B", 200.0, seed=0)
    V, L, dt = 20.0, 2.54, 1e-3
    t = np.arange(5000) * dt
    U = rd.wheel_inputs(t, V, L)
    k = int(round(L / V / dt))  # 127 samples = 2.54 m at 20 m/s
    np.testing.assert_allclose(U[k:, 0], U[:-k, 2], atol=1e-12)
    np.testing.assert_allclose(U[k:, 1], U[:-k, 3], atol=1e-12)
    with pytest.raises(ValueError, match="too short"):
        rd.wheel_inputs(np.arange(20000) * dt, V, L)


def test_bad_belgian_file(tmp_path):
    p = tmp_path / "bb.csv"
    p.write_text("s,z1,z2\n0,1,2\n")
    with pytest.raises(ValueError, match="header"):
        road.load_belgian_block(p)
