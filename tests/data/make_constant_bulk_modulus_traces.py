"""Write ``constant_bulk_modulus_traces.npz``: the hydraulic rung's default run (RK4 at its
stable sub-step, 1 ms physics step) of the chart's scenes with the constant bulk modulus and no
pressure floor, as the rung was before the oil's low-pressure behaviour was modelled (commit
10159b9). Run it with that commit's checkout on the path:

    PYTHONPATH=<checkout> python tests/data/make_constant_bulk_modulus_traces.py OUT.npz

``tests/test_fidelity_low_pressure.py`` checks that the present rung, with no entrained air,
reproduces these traces wherever the pressures stay above the vapour pressure."""

import sys

import numpy as np

from drs_model import DRSParams
from drs_model.fidelity import make_rung
from drs_model.fidelity.scenes import SCENES, _apply

NAMES = ("open-hold-close", "open-hold-close-100ms", "force-step", "supply-loss")


def trace(scene):
    rung = make_rung("hydraulic", DRSParams(), 1e-3)
    n = int(round(scene.duration / 1e-3))
    events = sorted(scene.events, key=lambda e: e[0])
    out, k_event = [], 0
    for _ in range(n):
        while k_event < len(events) and events[k_event][0] <= rung.t + 1e-12:
            _apply(rung, events[k_event][1], events[k_event][2])
            k_event += 1
        rung.advance(1)
        st = rung.state
        out.append((st.t, st.q[0], st.piston_force, *rung.y))
    return np.array(out)


if __name__ == "__main__":
    np.savez_compressed(sys.argv[1], **{name: trace(SCENES[name]) for name in NAMES})
