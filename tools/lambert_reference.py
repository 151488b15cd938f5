#!/usr/bin/env python3
"""Reference values for the statistical test files in tests/statistical/, computed here by
methods independent of the renderer (pure Python, double precision):

  lights  Irradiance at a floor point under a polygonal area light of constant radiance L, by
          Lambert's closed-form polygon formula (Arvo's thesis, eqs. 3.1-3.3):
              E = (L / 2) * |sum_i Theta_i * (Gamma_i . n)|,
          Theta_i the angle the edge (v_i, v_{i+1}) subtends at the point, Gamma_i the unit
          normal of the plane through the point and that edge. A diffuse floor of albedo rho then
          shows radiance rho * E / pi. The test camera has a 1x1 image and a 0.01 degree field
          of view, so it sees a patch of the floor about 1e-4 wide; the script bounds how much E
          changes over that patch (printed as "footprint error"). The quad's value is also the
          reference of narrow_camera_ttest.xml and zero_area_light_ttest.xml, whose cameras
          (fov 1e-6, 0.01 above the floor) see a far smaller patch.
  albedo  Directional albedo of Nori's microfacet BRDF (Beckmann D, Walter's rational Smith G1,
          dielectric Fresnel, Lambertian kd, ks = 1 - max(kd)): the expected BSDF sampling weight
          int f(wi, wo) cos(theta_o) dwo. The diffuse part is kd; the specular part is integrated
          over half vectors h (dwo = 4 (wo.h) dwh), where the Beckmann peak sits at the pole,
          with the exact boundary of the region wo.n > 0 found per azimuth so that the
          adaptive Gauss-Kronrod quadrature only sees smooth integrands. By reciprocity the same
          numbers are the radiance a microfacet floor inside a box emitting radiance 1 shows at
          that angle (narrow_camera_ttest.xml).

Usage: python3 tools/lambert_reference.py [lights|albedo]   (default: both)
"""
import math
import sys

# --------------------------------------------------------------------------------------------
# small vector helpers


def add(a, b):
    return tuple(x + y for x, y in zip(a, b))


def sub(a, b):
    return tuple(x - y for x, y in zip(a, b))


def scale(a, s):
    return tuple(x * s for x in a)


def dot(a, b):
    return sum(x * y for x, y in zip(a, b))


def cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def norm(a):
    return math.sqrt(dot(a, a))


def normalize(a):
    return scale(a, 1.0 / norm(a))


# --------------------------------------------------------------------------------------------
# Nori-style transforms: operations apply in the order they are listed in the XML.


def op_scale(s):
    return lambda p: (p[0] * s[0], p[1] * s[1], p[2] * s[2])


def op_translate(t):
    return lambda p: add(p, t)


def op_rotate(axis, degrees):
    k = normalize(axis)
    a = math.radians(degrees)
    c, s = math.cos(a), math.sin(a)

    def rot(p):  # Rodrigues
        return add(add(scale(p, c), scale(cross(k, p), s)), scale(k, dot(k, p) * (1 - c)))

    return rot


def apply(ops, p):
    for op in ops:
        p = op(p)
    return p


def polygon_irradiance(x, n, vertices, radiance=1.0):
    """Lambert: irradiance at x (normal n) from a polygon of constant radiance."""
    total = 0.0
    count = len(vertices)
    for i in range(count):
        a = sub(vertices[i], x)
        b = sub(vertices[(i + 1) % count], x)
        theta = math.acos(max(-1.0, min(1.0, dot(a, b) / (norm(a) * norm(b)))))
        gamma = normalize(cross(a, b))
        total += theta * dot(gamma, n)
    return 0.5 * radiance * abs(total)


# The lights of tests/statistical/lights_*.xml: mesh vertices (scenes/meshes/*.obj) and the
# transforms written in those files.
TRIANGLE = [(-1, 0, -1), (1, 0, -1), (0, 0, 1)]
QUAD = [(-1, 0, -1), (1, 0, -1), (1, 0, 1), (-1, 0, 1)]
LIGHTS = {
    "triangle": (TRIANGLE, [op_scale((0.6, 1, 0.4)), op_rotate((1, 0, 0), 180),
                            op_rotate((0, 0, 1), 20), op_translate((0.3, 1.0, -0.2))]),
    "quad": (QUAD, [op_scale((0.5, 1, 0.3)), op_rotate((1, 0, 0), 180),
                    op_rotate((0, 1, 0), 35), op_rotate((1, 0, 0), -15),
                    op_translate((-0.4, 0.8, 0.25))]),
}
ALBEDO = 0.5  # of the floor
FOV_DEGREES = 0.01
CAMERA_HEIGHT = 0.5  # straight above the floor point (0, 0, 0)


def lights():
    x, n = (0.0, 0.0, 0.0), (0.0, 1.0, 0.0)
    half = CAMERA_HEIGHT * math.tan(math.radians(FOV_DEGREES / 2))
    for name, (mesh, ops) in LIGHTS.items():
        verts = [apply(ops, v) for v in mesh]
        assert all(v[1] > 0 for v in verts), "the light must lie above the floor's horizon"
        e = polygon_irradiance(x, n, verts)
        # The camera sees the square [-half, half]^2 of the floor: E is smooth there, so its
        # extreme values over the footprint are at the corners or the centre.
        corners = [polygon_irradiance((sx * half, 0.0, sz * half), n, verts)
                   for sx in (-1, 1) for sz in (-1, 1)]
        err = max(abs(c - e) for c in corners) / e
        print("%-8s E = %.9f  radiance rho*E/pi = %.9f  (footprint error < %.1e relative)"
              % (name, e, ALBEDO * e / math.pi, err))


# --------------------------------------------------------------------------------------------
# Adaptive Gauss-Kronrod (7-15) quadrature.

XGK = [0.991455371120812639206854697526329, 0.949107912342758524526189684047851,
       0.864864423359769072789712788640926, 0.741531185599394439863864773280788,
       0.586087235467691130294144845693013, 0.405845151377397166906606412076961,
       0.207784955007898467600689403773245, 0.000000000000000000000000000000000]
WGK = [0.022935322010529224963732008058970, 0.063092092629978553290700663189204,
       0.104790010322250183839876322541518, 0.140653259715525918745189590510238,
       0.169004726639267902826583426598550, 0.190350578064785409913256402421014,
       0.204432940075298892414161999234649, 0.209482141084727828012999174891714]
WG = [0.129484966168869693270611432679082, 0.279705391489276667901467771423780,
      0.381830050505118944950369775488975, 0.417959183673469387755102040816327]


def gk15(f, a, b):
    c, h = 0.5 * (a + b), 0.5 * (b - a)
    fc = f(c)
    kron, gauss = WGK[7] * fc, WG[3] * fc
    for j in range(7):
        x = h * XGK[j]
        f1, f2 = f(c - x), f(c + x)
        kron += WGK[j] * (f1 + f2)
        if j % 2 == 1:
            gauss += WG[j // 2] * (f1 + f2)
    return kron * h, abs((kron - gauss) * h)


def integrate(f, a, b, tol=1e-10, depth=0):
    value, err = gk15(f, a, b)
    if err <= tol or depth > 40:
        return value
    m = 0.5 * (a + b)
    return integrate(f, a, m, tol / 2, depth + 1) + integrate(f, m, b, tol / 2, depth + 1)


# --------------------------------------------------------------------------------------------
# Nori's microfacet BRDF, written from its definition.


def fresnel(cos_i, ext_ior, int_ior):
    eta_i, eta_t = ext_ior, int_ior
    if ext_ior == int_ior:
        return 0.0
    if cos_i < 0:
        eta_i, eta_t, cos_i = eta_t, eta_i, -cos_i
    cos_i = min(cos_i, 1.0)
    sin_t2 = (eta_i / eta_t) ** 2 * (1 - cos_i * cos_i)
    if sin_t2 >= 1:
        return 1.0
    cos_t = math.sqrt(1 - sin_t2)
    rs = (eta_i * cos_i - eta_t * cos_t) / (eta_i * cos_i + eta_t * cos_t)
    rp = (eta_t * cos_i - eta_i * cos_t) / (eta_t * cos_i + eta_i * cos_t)
    return 0.5 * (rs * rs + rp * rp)


def beckmann_d(h, alpha):
    c = h[2]
    if c <= 0:
        return 0.0
    tan2 = (1 - c * c) / (c * c)
    return math.exp(-tan2 / (alpha * alpha)) / (math.pi * alpha * alpha * c ** 4)


def smith_g1(v, h, alpha):
    cos_v = v[2]
    if cos_v == 0 or dot(v, h) / cos_v <= 0:
        return 0.0
    sin_v = math.sqrt(max(0.0, 1 - cos_v * cos_v))
    tan_v = sin_v / cos_v
    if tan_v == 0:
        return 1.0
    b = 1.0 / (alpha * abs(tan_v))
    if b >= 1.6:
        return 1.0
    return (3.535 * b + 2.181 * b * b) / (1 + 2.276 * b + 2.577 * b * b)


def microfacet_albedo(theta_deg, alpha, kd, int_ior=1.5046, ext_ior=1.000277):
    """Expected sampling weight (luminance) for a grey kd at incident angle theta (phi = 0)."""
    ks = 1.0 - kd
    t = math.radians(theta_deg)
    wi = (math.sin(t), 0.0, math.cos(t))

    def half(theta_h, phi_h):
        s = math.sin(theta_h)
        return (s * math.cos(phi_h), s * math.sin(phi_h), math.cos(theta_h))

    def reflect_z(h):  # wo.z for wo = 2 (wi.h) h - wi
        return 2 * dot(wi, h) * h[2] - wi[2]

    def spec(theta_h, phi_h):
        h = half(theta_h, phi_h)
        wih = dot(wi, h)
        wo = sub(scale(h, 2 * wih), wi)
        if wo[2] <= 0 or wih <= 0:
            return 0.0
        g = smith_g1(wi, h, alpha) * smith_g1(wo, h, alpha)
        # f cos_o dwo with f = D F G / (4 cos_i cos_o) and dwo = 4 (wo.h) dwh; wo.h = wi.h.
        value = beckmann_d(h, alpha) * fresnel(wih, ext_ior, int_ior) * g * wih / wi[2]
        return value * math.sin(theta_h)  # dwh = sin(theta_h) dtheta_h dphi_h

    def theta_limit(phi_h):
        # Largest theta_h with wo.z > 0 along this azimuth (wo.z decreases from cos(theta_i)
        # at theta_h = 0 once it turns negative), found by bisection.
        lo, hi = 0.0, math.pi / 2
        if reflect_z(half(hi, phi_h)) > 0:
            return hi
        for _ in range(200):
            mid = 0.5 * (lo + hi)
            if reflect_z(half(mid, phi_h)) > 0:
                lo = mid
            else:
                hi = mid
        return lo

    # Beyond theta_h where tan^2 / alpha^2 = 40, D is below e^-40 of its peak.
    cap = math.atan(alpha * math.sqrt(40.0))

    def over_theta(phi_h):
        top = min(theta_limit(phi_h), cap)
        return integrate(lambda th: spec(th, phi_h), 0.0, top, 1e-11)

    # Symmetric in phi_h -> -phi_h (wi lies in the xz plane): integrate [0, pi] twice.
    specular = 2 * integrate(over_theta, 0.0, math.pi, 1e-10)
    return kd + ks * specular


ALBEDO_CASES = [  # (alpha, kd, angles): as in tests/statistical/microfacet_albedo_ttest.xml
    (0.1, 0.2, [0, 30, 60, 80]),
    (0.3, 0.5, [0, 30, 60, 80]),
    (0.7, 0.0, [0, 30, 60, 80]),
]


def albedo():
    for alpha, kd, angles in ALBEDO_CASES:
        values = [microfacet_albedo(a, alpha, kd) for a in angles]
        print("alpha %.2f kd %.2f angles %s -> %s"
              % (alpha, kd, ", ".join("%g" % a for a in angles),
                 ", ".join("%.6f" % v for v in values)))


if __name__ == "__main__":
    what = sys.argv[1] if len(sys.argv) > 1 else "all"
    if what in ("lights", "all"):
        lights()
    if what in ("albedo", "all"):
        albedo()
