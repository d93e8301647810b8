"""A cantilever change (the new lever sits 310 nm away over the sample; only
the simulator knows) and a 1.4 um scan around a landmark pillar: the
firmware takes the pillar's displacement as the work space's new offset.
The re-registration error is the card's offset (FW_STATE.objects.drift_nm) against
the simulator's (SIM_TRUTH), and the models' error after it: the card's
particles against the true ones at the end of the run, after a push. The
same run without the landmark scan shows what the change costs unmended."""

import numpy as np

from analysis.units import show
from analysis.paper import common

NAME = "landmark"
TITLE = "Landmark recovery after a lever change"
FIGURES = "section II"


def runs(size):
    return [common.Run(name="with_landmark_scan", scene="landmark.yaml", cost_s=5),
            common.Run(name="without", scene="landmark.yaml", settings={"operator.local_scans": [], "expect": ["fidelity"]},
                       cost_s=5)]   # unmended on purpose: its verdict expects the display off the sample


def analyse(dirs, exp_dir, size):
    w, wo = common.model_states(dirs["with_landmark_scan"]), common.model_states(dirs["without"])
    _, f_end, t_end = w[-1]
    change = float(np.hypot(*t_end.drift_nm))
    res = common.Result()
    res.rows = [
        common.Row("re-registered offset x", "nm", key="landmark.offset", bench=f_end.drift_nm[0], truth=t_end.drift_nm[0],
                   runs=("with_landmark_scan",),
                   note="the card's work-space offset from the landmark scan (FW_STATE.objects.drift_nm)"),
        common.Row("re-registered offset y", "nm", key="landmark.offset", bench=f_end.drift_nm[1], truth=t_end.drift_nm[1],
                   runs=("with_landmark_scan",)),
        common.Row("models' error at the end, with the landmark scan", "nm", key="landmark.models_error",
                   bench=common.model_error(f_end, t_end), runs=("with_landmark_scan",),
                   note="largest distance between a modelled and a true particle, after a push on the moved work space"),
        common.Row("models' error at the end, without it", "nm", key="landmark.unmended_error",
                   bench=common.model_error(wo[-1][1], wo[-1][2]), runs=("without",),
                   note="unmended, the models are off by the whole lever change (shown, not judged)"),
    ]
    res.notes.append(f"the lever change moved the work space by {show(change, 'nm')} (the simulator's)")
    res.figures = [("Models' error against time, with and without the landmark scan", plot(exp_dir, w, wo))]
    return res


def plot(exp_dir, w, wo):
    p = common.plt()
    fig, ax = p.subplots(figsize=(6.4, 3.6))
    for st, lab in ((w, "with the landmark scan"), (wo, "without")):
        ax.plot([f.utime * 1e-6 for _, f, _ in st], [common.model_error(f, t) for _, f, t in st], lw=1, label=lab)
    ax.set_yscale("symlog", linthresh=1)
    ax.set_xlabel("simulated time (s)")
    ax.set_ylabel("largest model error (nm)")
    ax.legend(fontsize=8)
    return common.save(fig, exp_dir, "model_error.png")
