"""Sources of the plug-ins the tests write to a temporary folder and load by path, as a
researcher would (``--plugin FILE.py``, a campaign's ``plugins``): one text, shared by the
command-line and the campaign tests."""

from __future__ import annotations

#: a v_y observer reading the Revs log's longitudinal accelerometer (not a schema column):
#: dv_y/dt = a_y - v_x r - gain v_y + 0 * a_x, explicit Euler, readable step only;
#: ``AX_PLUGIN.format(name=...)`` registers it under ``name``
AX_PLUGIN = '''
import numpy as np

from vehicle_observers.core.protocol import ObserverBase
from vehicle_observers.estimation import register_observer


class AxVy(ObserverBase):
    state_names = ("vy_mps",)
    input_names = ("vx_mps", "ax_mps2")
    output_names = ("yaw_rate_radps", "ay_mps2")

    def __init__(self, vehicle, dt, gain=2.0):
        self.k = float(gain)

    def initial_state(self, t, u, y, x0=None):
        return np.zeros(1)

    def step(self, z, k, t, u, y):
        vx, ax = u[k - 1]
        r, ay = y[k - 1]
        return z + (t[k] - t[k - 1]) * (ay - vx * r - self.k * z + 0.0 * ax)

    def estimate(self, z):
        return z


register_observer("{name}", AxVy, "v_y from a_y - v_x r with leakage; reads ax_mps2")
'''

#: a truth plant "kinematic" (no tyre slip dynamics) for campaigns, appended to a plug-in
KINEMATIC_PLANT = '''

from vehicle_observers.campaign.plants import register_plant
from vehicle_observers.campaign.truths import car_vehicle


def kinematic(car, m, rate):
    p = car_vehicle(car).params
    L = p.a_f + p.a_r
    t, d, v = m.t, m.delta_ref, m.v_ref
    beta = np.arctan(p.a_r * np.tan(d) / L)
    r = v * np.tan(d) / L
    Ff, Fr = p.m * v * r * p.a_r / L, p.m * v * r * p.a_f / L
    return {"t": t, "vx": v, "delta": d, "r": r, "ay": v * r, "vy": v * np.tan(beta),
            "Ff": Ff, "Fr": Fr}


register_plant("kinematic", kinematic, native_rate=100.0, cars=("bmw_320i",))
'''

#: the campaign tests' plug-in: ``ax-vy-c`` (campaign logs have ``ax_mps2``) and the plant
CAMPAIGN_PLUGIN = AX_PLUGIN.format(name="ax-vy-c") + KINEMATIC_PLANT
