"""A run's state as Foxglove's own message types, for analysis/export.py's
MCAP file. The schemas are those of Foxglove's published package
(foxglove-schemas-protobuf, pinned in tools/setup.sh), protobuf-encoded:
none is written here.

    schema(cls)                 (name, FileDescriptorSet bytes) of a message class
    transform(utime, child, tip_nm)             foxglove.FrameTransform "afm" -> child
    pose(utime, tip_nm)                         foxglove.PoseInFrame in "afm"
    scene(utime, name, whole, tip_nm, force_nN, probe, rgba)
                                                foxglove.SceneUpdate: entity `name`
    image(utime, png)                           foxglove.CompressedImage, "afm"
    grid(header, values)                        foxglove.Grid of a GSF file

Units and frames: every position in metres in frame "afm" (the AFM frame:
the lcmtypes' nm x 1e-9); a timestamp is the simulated time (utime, us).
The scene entity draws each particle as a sphere of its radius, each wire as
a line of its diameter through its nodes at its axis height, the apex as a
sphere of 20 nm, the lever as a box of the scene's probe.lever_length_um
along +x from the apex, its underside probe.tip_height_um above the apex,
30 um wide and 2 um thick (probe: (lever_length_um, tip_height_um); the
width and thickness are drawn, not the scene's),
and the force on the tip as an arrow from the apex along it, 10 nm per nN."""
import math

from foxglove_schemas_protobuf.CompressedImage_pb2 import CompressedImage
from foxglove_schemas_protobuf.FrameTransform_pb2 import FrameTransform
from foxglove_schemas_protobuf.Grid_pb2 import Grid
from foxglove_schemas_protobuf.PackedElementField_pb2 import PackedElementField
from foxglove_schemas_protobuf.PoseInFrame_pb2 import PoseInFrame
from foxglove_schemas_protobuf.SceneUpdate_pb2 import SceneUpdate

NM = 1e-9
FRAME = "afm"
APEX_M = 20 * NM
ARROW_M_PER_NN = 10 * NM
LEVER_W_M, LEVER_T_M = 30e-6, 2e-6
CLASSES = (CompressedImage, FrameTransform, Grid, PoseInFrame, SceneUpdate)


def schema(cls):
    """(full name, FileDescriptorSet) of a protobuf message class: its file
    and every file it imports, dependencies first (MCAP's protobuf profile)."""
    from google.protobuf import descriptor_pb2
    fds = descriptor_pb2.FileDescriptorSet()
    seen = set()

    def add(fd):
        if fd.name in seen:
            return
        seen.add(fd.name)
        for dep in fd.dependencies:
            add(dep)
        fd.CopyToProto(fds.file.add())
    add(cls.DESCRIPTOR.file)
    return cls.DESCRIPTOR.full_name, fds.SerializeToString()


def _stamp(ts, utime_us):
    ts.seconds, ts.nanos = int(utime_us // 1_000_000), int(utime_us % 1_000_000) * 1000


def _xyz(v, nm):
    v.x, v.y, v.z = (float(c) * NM for c in nm)


def transform(utime_us, child, tip_nm):
    m = FrameTransform(parent_frame_id=FRAME, child_frame_id=child)
    _stamp(m.timestamp, utime_us)
    _xyz(m.translation, tip_nm)
    m.rotation.w = 1.0
    return m


def pose(utime_us, tip_nm):
    m = PoseInFrame(frame_id=FRAME)
    _stamp(m.timestamp, utime_us)
    _xyz(m.pose.position, tip_nm)
    m.pose.orientation.w = 1.0
    return m


def _towards(q, v):
    """q: the rotation taking +x (an arrow's axis) to the direction of v."""
    n = math.sqrt(sum(c * c for c in v)) or 1.0
    x, y, z = (c / n for c in v)
    w, qx, qy, qz = 1.0 + x, 0.0, -z, y           # half-way quaternion: (1 + x.v, x cross v)
    s = math.sqrt(w * w + qy * qy + qz * qz)
    if s < 1e-9:                                   # v along -x: half a turn about z
        w, qy, qz, s = 0.0, 0.0, 1.0, 1.0
    q.w, q.x, q.y, q.z = w / s, qx / s, qy / s, qz / s


def _color(c, rgba):
    c.r, c.g, c.b, c.a = rgba


def _objects(e, whole, rgba):
    for p in whole.particles:
        s = e.spheres.add()
        s.pose.position.x, s.pose.position.y, s.pose.position.z = p.x_nm * NM, p.y_nm * NM, p.radius_nm * NM
        s.pose.orientation.w = 1.0
        s.size.x = s.size.y = s.size.z = 2 * p.radius_nm * NM
        _color(s.color, rgba)
    for w in whole.wires:
        ln = e.lines.add(type=0, thickness=w.diameter_nm * NM, scale_invariant=False)   # LINE_STRIP
        ln.pose.orientation.w = 1.0
        for x, y in zip(w.x_nm, w.y_nm):
            pt = ln.points.add()
            pt.x, pt.y, pt.z = x * NM, y * NM, w.axis_z_nm * NM
        _color(ln.color, rgba)


def _probe(e, tip_nm, force_nN, probe, rgba):
    lever_um, tip_um = probe
    apex = e.spheres.add()
    _xyz(apex.pose.position, tip_nm)
    apex.pose.orientation.w = 1.0
    apex.size.x = apex.size.y = apex.size.z = APEX_M
    _color(apex.color, rgba)
    lever = e.cubes.add()
    lever.pose.position.x = tip_nm[0] * NM + lever_um * 1e-6 / 2
    lever.pose.position.y = tip_nm[1] * NM
    lever.pose.position.z = tip_nm[2] * NM + tip_um * 1e-6 + LEVER_T_M / 2
    lever.pose.orientation.w = 1.0
    lever.size.x, lever.size.y, lever.size.z = lever_um * 1e-6, LEVER_W_M, LEVER_T_M
    _color(lever.color, (0.6, 0.6, 0.6, 0.5))
    size = math.sqrt(sum(c * c for c in force_nN)) * ARROW_M_PER_NN
    if size > 0:
        a = e.arrows.add(shaft_length=size * 0.8, head_length=size * 0.2, shaft_diameter=APEX_M / 4, head_diameter=APEX_M / 2)
        _xyz(a.pose.position, tip_nm)
        _towards(a.pose.orientation, force_nN)
        _color(a.color, (1.0, 0.3, 0.1, 1.0))


def scene(utime_us, name, whole, tip_nm, force_nN, probe, rgba):
    """A SceneUpdate replacing entity `name`: the objects `whole` (an
    objects_t with every object), the apex, the lever and the force."""
    m = SceneUpdate()
    e = m.entities.add(frame_id=FRAME, id=name, frame_locked=False)
    _stamp(e.timestamp, utime_us)
    _objects(e, whole, rgba)
    _probe(e, tip_nm, force_nN, probe, rgba)
    return m


def image(utime_us, png):
    m = CompressedImage(frame_id=FRAME, data=png, format="png")
    _stamp(m.timestamp, utime_us)
    return m


def grid(header, values):
    """A GSF file (analysis.gsf.read) as a Grid in metres, frame "afm", its
    rows from the scan's bottom edge (-y) up, as Grid's rows grow along +y."""
    import numpy as np
    nx, ny = int(header["XRes"]), int(header["YRes"])
    z = header.get("ZUnits", "m")
    m = Grid(frame_id=FRAME, column_count=nx, row_stride=4 * nx, cell_stride=4,
             data=np.ascontiguousarray(np.flipud(values), dtype="<f4").tobytes())
    _stamp(m.timestamp, round(float(header.get("SimTime_s", 0)) * 1e6))
    m.pose.position.x, m.pose.position.y = float(header.get("XOffset", 0)), float(header.get("YOffset", 0))
    m.pose.orientation.w = 1.0
    m.cell_size.x, m.cell_size.y = float(header["XReal"]) / nx, float(header["YReal"]) / ny
    name = ("lateral_" if header.get("Channel") == "Lateral" else "height_") + z
    m.fields.add(name=name, offset=0, type=PackedElementField.FLOAT32)
    return m
