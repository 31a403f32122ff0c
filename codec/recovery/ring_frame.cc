#include "codec/recovery/ring_frame.h"

#include <algorithm>
#include <cmath>

namespace meshstream {

namespace {

// Eigenvector of the smallest eigenvalue of a symmetric 3x3 matrix: the
// eigenvalue in closed form (the trigonometric solution of the
// characteristic cubic), the vector as the longest cross product of two rows
// of m - lambda I. Zero when the eigenvalue is not simple enough to define one.
Vec3d SmallestEigenvector(const double m[3][3]) {
  const double p1 = m[0][1] * m[0][1] + m[0][2] * m[0][2] + m[1][2] * m[1][2];
  const double q = (m[0][0] + m[1][1] + m[2][2]) / 3;
  const double p2 = (m[0][0] - q) * (m[0][0] - q) + (m[1][1] - q) * (m[1][1] - q) + (m[2][2] - q) * (m[2][2] - q) + 2 * p1;
  const double p = std::sqrt(p2 / 6);
  double lambda = q;
  if (p > 1e-300) {
    double b[3][3];
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) b[i][j] = (m[i][j] - (i == j ? q : 0)) / p;
    const double det = b[0][0] * (b[1][1] * b[2][2] - b[1][2] * b[2][1]) -
                       b[0][1] * (b[1][0] * b[2][2] - b[1][2] * b[2][0]) +
                       b[0][2] * (b[1][0] * b[2][1] - b[1][1] * b[2][0]);
    const double r = std::clamp(det / 2, -1.0, 1.0);
    const double phi = std::acos(r) / 3;
    lambda = q + 2 * p * std::cos(phi + 2.0943951023931953);  // the smallest of the three
  }
  const Vec3d r0 = {m[0][0] - lambda, m[0][1], m[0][2]};
  const Vec3d r1 = {m[1][0], m[1][1] - lambda, m[1][2]};
  const Vec3d r2 = {m[2][0], m[2][1], m[2][2] - lambda};
  Vec3d best = Cross(r0, r1);
  for (const Vec3d& c : {Cross(r0, r2), Cross(r1, r2)}) {
    if (Dot(c, c) > Dot(best, best)) best = c;
  }
  return best;
}

}  // namespace

Vec2d RingFrame::Project(const Vec3d& p) const {
  const Vec3d d = Sub(p, origin);
  return {Dot(d, axis_u), Dot(d, axis_v)};
}

void FitRingFrame(const Vec3i& w, const std::vector<Vec3i>& ring, RingFrame* out, bool least_squares) {
  RingFrame& f = *out;
  f.w = ToDouble(w);
  f.ring.clear();
  f.ring_uv.clear();
  Vec3d c = f.w;
  for (const Vec3i& p : ring) {
    f.ring.push_back(ToDouble(p));
    for (int k = 0; k < 3; ++k) c[k] += f.ring.back()[k];
  }
  c = Scale(c, 1.0 / double(ring.size() + 1));
  double m[3][3] = {};
  auto add = [&](const Vec3d& p) {
    const Vec3d d = Sub(p, c);
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) m[i][j] += d[i] * d[j];
  };
  if (least_squares) {
    add(f.w);
    for (const Vec3d& p : f.ring) add(p);
  }
  // The fan's normal orients the plane; it also stands in for a plane the
  // points do not define (all on one line or one point).
  Vec3d fan{0, 0, 0};
  for (size_t k = 0; k < f.ring.size(); ++k) {
    const Vec3d e = Cross(Sub(f.ring[k], f.w), Sub(f.ring[(k + 1) % f.ring.size()], f.w));
    for (int i = 0; i < 3; ++i) fan[i] += e[i];
  }
  Vec3d n = least_squares ? SmallestEigenvector(m) : fan;
  if (Norm(n) < 1e-9 * (1 + Norm(fan))) n = fan;
  if (Dot(n, fan) < 0) n = Scale(n, -1);
  if (Norm(n) < 1e-12) n = {0, 0, 1};
  n = Scale(n, 1.0 / Norm(n));
  // Any axis perpendicular to n.
  const Vec3d helper = std::fabs(n[0]) < 0.9 ? Vec3d{1, 0, 0} : Vec3d{0, 1, 0};
  Vec3d u = Cross(helper, n);
  u = Scale(u, 1.0 / Norm(u));
  f.normal = n;
  f.axis_u = u;
  f.axis_v = Cross(n, u);
  f.origin = c;
  f.w_uv = f.Project(f.w);
  for (const Vec3d& p : f.ring) f.ring_uv.push_back(f.Project(p));
}

}  // namespace meshstream
