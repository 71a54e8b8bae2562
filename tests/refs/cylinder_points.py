#!/usr/bin/env python3
"""Mitsuba 3.9.1 (scalar_rgb) point values behind tests/scene/cylinder_quirks.rs: for each of the
three cylinders (the same XML as the test), the surface area, bounding box, `scene.ray_intersect`
of a few rays (t, p, n, sh_frame.n, uv, dp_du, dp_dv, or a miss) and `sample_position` (p, n, uv,
pdf). Usage: /work/.venv-mitsuba/bin/python tests/refs/cylinder_points.py scaled|sheared|rotated
"""
import mitsuba as mi, sys
mi.set_variant('scalar_rgb')
shapes = {
 'scaled': '<transform name="to_world"><scale x="1" y="2" z="1.5"/><rotate x="1" angle="70"/><translate z="-0.5"/></transform><float name="radius" value="0.5"/>',
 'sheared': '<transform name="to_world"><matrix value="1 0.4 0.3 0.1  0 0.8 -0.2 0  0.1 0.5 1.2 -0.3  0 0 0 1"/></transform><float name="radius" value="0.4"/><point name="p0" x="0.1" y="-0.2" z="0"/><point name="p1" x="-0.1" y="0.3" z="0.9"/>',
 'rotated': '<transform name="to_world"><rotate x="0.6" y="0.3" z="1.2" angle="50"/><rotate x="1" angle="80"/></transform><float name="radius" value="0.6"/>',
}
rays = [((0.05,3,0.1),(0,-1,0)), ((0.3,-0.1,3),(-0.1,0.05,-1)), ((0.0,0.0,0.0),(0.3,0.8,-0.4)), ((-2,0.2,0.1),(1,0,0.05))]
us = [(0.3,0.7),(0.8,0.15)]
name = sys.argv[1]
xml = f'<scene version="3.0.0"><shape type="cylinder">{shapes[name]}</shape></scene>'
sc = mi.load_string(xml)
sh = sc.shapes()[0]
print(name, 'area', sh.surface_area()[0] if hasattr(sh.surface_area(),'__len__') else sh.surface_area(), 'bbox', sh.bbox())
c=sh.bbox().center()
c=[float(c[0]),float(c[1]),float(c[2])]
rays=[((c[0]+0.05,c[1]+0.02,c[2]+3),(0,0,-1)),((c[0]+3,c[1]-0.03,c[2]+0.04),(-1,0.01,0)),((c[0]-0.02,c[1]-3,c[2]+0.05),(0.01,1,0)),((c[0]+0.01,c[1]+0.01,c[2]),(0.3,0.8,-0.4)),((c[0]+0.01,c[1]+0.01,c[2]),(-0.5,0.2,0.6))]
for o,d in rays:
    d = mi.Vector3f(d); d = d/ (d[0]**2+d[1]**2+d[2]**2)**0.5
    si = sc.ray_intersect(mi.Ray3f(mi.Point3f(o), d))
    if not si.is_valid():
        print('ray', o, list(d), 'miss'); continue
    print('ray', o, [float(x) for x in d], 't', float(si.t), 'p', list(si.p), 'n', list(si.n), 'sh', list(si.sh_frame.n), 'uv', list(si.uv), 'dpdu', list(si.dp_du), 'dpdv', list(si.dp_dv))
for u in us:
    ps = sh.sample_position(0.0, mi.Point2f(u))
    print('pos', u, 'p', list(ps.p), 'n', list(ps.n), 'uv', list(ps.uv), 'pdf', float(ps.pdf))
