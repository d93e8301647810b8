"""What the page is sent about a frame (docs/view.md): one JSON "frame"
message built from a view_frame_t (a live run) or from a run's log and its
frame file (a recorded run), and the page's hello. The flag names and bits
come from the generated fw_state_t (lcmtypes/fw_state_t.lcm), not a copy."""
from analysis import afmlog


def flag_bits():
    """{name: bit} of fw_state_t's FLAG_* constants."""
    t = afmlog.afm.fw_state_t
    return {k[5:]: getattr(t, k) for k in dir(t) if k.startswith("FLAG_")}


def hello(mode, **extra):
    """The first message a page gets: the mode (live, recorded) and the flags."""
    return dict({"type": "hello", "mode": mode, "flags": flag_bits()}, **extra)


def _round(v, nd=4):
    return [round(float(x), nd) for x in v]


def samples_of(m):
    """A view_frame_t's strip chart samples as series (t_s; card force nN; hand N)."""
    return {"t": [u * 1e-6 for u in m.sample_utime], "fx": _round(m.sample_fx_nN), "fy": _round(m.sample_fy_nN),
            "fz": _round(m.sample_fz_nN), "hx": _round(m.sample_hand_x_N, 6), "hy": _round(m.sample_hand_y_N, 6),
            "hz": _round(m.sample_hand_z_N, 6)}


def frame_meta(*, index, utime, seq, frames_total, width, height, field_nm, tip_nm, force_nN, hand_N, flags,
               particles, image, skipped=0, samples=None):
    """The JSON "frame" message; particles: [(id, x_nm, y_nm, radius_nm)]."""
    return {"type": "frame", "index": int(index), "t_s": utime * 1e-6, "seq": int(seq), "frames_total": int(frames_total),
            "width": int(width), "height": int(height), "field_nm": _round(field_nm, 3) if field_nm else None, "tip_nm": _round(tip_nm, 3),
            "force_nN": _round(force_nN), "hand_N": _round(hand_N, 6), "flags": int(flags),
            "particles": [[int(i), round(x, 2), round(y, 2), round(r, 2)] for i, x, y, r in particles],
            "image": image, "skipped": int(skipped), "samples": samples}


def from_view_frame(m):
    """(meta, jpeg bytes) of a view_frame_t as the bridge passed it on."""
    meta = frame_meta(index=m.index, utime=m.utime, seq=m.seq, frames_total=m.frames_total, width=m.width,
                      height=m.height, field_nm=m.field_nm, tip_nm=m.tip_nm, force_nN=m.force_nN, hand_N=m.hand_N,
                      flags=m.flags, particles=[(p.id, p.x_nm, p.y_nm, p.radius_nm) for p in m.particles],
                      image="image/jpeg", skipped=m.skipped, samples=samples_of(m))
    return meta, bytes(m.jpeg)
