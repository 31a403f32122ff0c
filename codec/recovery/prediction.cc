#include "codec/recovery/prediction.h"

#include <algorithm>
#include <cmath>

namespace meshstream {

namespace {

// Distance from p to the segment [a, b].
double SegmentDistance(const Vec2d& p, const Vec2d& a, const Vec2d& b) {
  const Vec2d ab = Sub(b, a), ap = Sub(p, a);
  const double len2 = ab[0] * ab[0] + ab[1] * ab[1];
  double t = len2 > 0 ? (ap[0] * ab[0] + ap[1] * ab[1]) / len2 : 0;
  t = std::clamp(t, 0.0, 1.0);
  return Distance(p, {a[0] + t * ab[0], a[1] + t * ab[1]});
}

// True when d lies strictly inside the circle through a, b, c (counter-
// clockwise or not).
bool InCircle(const Vec2d& a, const Vec2d& b, const Vec2d& c, const Vec2d& d) {
  const double ax = a[0] - d[0], ay = a[1] - d[1];
  const double bx = b[0] - d[0], by = b[1] - d[1];
  const double cx = c[0] - d[0], cy = c[1] - d[1];
  const double det = (ax * ax + ay * ay) * (bx * cy - cx * by) - (bx * bx + by * by) * (ax * cy - cx * ay) +
                     (cx * cx + cy * cy) * (ax * by - bx * ay);
  const double orient = Cross(Sub(b, a), Sub(c, a));
  return orient > 0 ? det > 1e-12 : det < -1e-12;
}

// The quadrilateral p, q, r, s (diagonal p-r to be flipped to q-s) is
// strictly convex: q and s on opposite sides of p-r, p and r on opposite
// sides of q-s.
bool FlipIsConvex(const Vec2d& p, const Vec2d& q, const Vec2d& r, const Vec2d& s) {
  const double a = Cross(Sub(r, p), Sub(q, p)), b = Cross(Sub(r, p), Sub(s, p));
  const double c = Cross(Sub(s, q), Sub(p, q)), d = Cross(Sub(s, q), Sub(r, q));
  return a * b < 0 && c * d < 0;
}

// std::lround for |x| < 2^31 (the values are clamped within the ring's int32
// range first), inline instead of a call into libm: the truncation and the
// remainder x - trunc(x) are exact, so rounding half away from zero gives
// the same integer.
int32_t RoundHalfAway(double x) {
  if (!(std::fabs(x) < 2147483648.0)) return x > 0 ? INT32_MAX : INT32_MIN;  // NaN: INT32_MIN (never, for finite rings)
  int64_t t = static_cast<int64_t>(x);
  const double rest = x - static_cast<double>(t);
  if (rest >= 0.5) ++t;
  else if (rest <= -0.5) --t;
  return static_cast<int32_t>(t);
}

}  // namespace

PredictedWings PredictWings(const RingFrame& f) {
  const size_t d = f.ring.size();
  // Step 2: the ring edge (ring[k], ring[k+1]) farthest from w.
  size_t far = 0;
  double far_dist = -1;
  for (size_t k = 0; k < d; ++k) {
    const double dist = SegmentDistance(f.w_uv, f.ring_uv[k], f.ring_uv[(k + 1) % d]);
    if (dist > far_dist) {
      far_dist = dist;
      far = k;
    }
  }
  // Steps 3-4: the new vertex at the centroid of (w, ring[k], ring[k+1]),
  // joined to all three: the split with b = ring[k], a = ring[k+1] (the one
  // triangle (w, ring[k], ring[k+1]) moves to the new vertex).
  PredictedWings out;
  out.b_at = far;
  out.a_at = (far + 1) % d;
  const Vec2d& p = f.ring_uv[far];
  const Vec2d& q = f.ring_uv[out.a_at];
  out.new_uv = {(f.w_uv[0] + p[0] + q[0]) / 3, (f.w_uv[1] + p[1] + q[1]) / 3};
  // Step 5: Delaunay flips of the edges w-a, n-a, w-b and n-b, the flips that
  // keep w and n adjacent. A flip is legal only if the edge it creates does
  // not exist yet: n's neighbours are ring[b..a] and w, w's are ring[a..b]
  // and n, so a flip may never make the path from b to a 0 or d faces long.
  const Vec2d& W = f.w_uv;
  const Vec2d& N = out.new_uv;
  auto at = [&](size_t k) -> const Vec2d& { return f.ring_uv[k % d]; };
  for (size_t round = 0; round < 2 * d; ++round) {
    bool flipped = false;
    const size_t path = (out.a_at + d - out.b_at) % d;
    // w-a, shared by (w, n, a) and (w, a, a+1): flip to n-(a+1).
    if (path + 1 < d && FlipIsConvex(W, N, at(out.a_at), at(out.a_at + 1)) &&
        InCircle(W, N, at(out.a_at), at(out.a_at + 1))) {
      out.a_at = (out.a_at + 1) % d;
      flipped = true;
    } else if (path > 1 && FlipIsConvex(N, at(out.a_at + d - 1), at(out.a_at), W) &&
               InCircle(N, at(out.a_at + d - 1), at(out.a_at), W)) {
      // n-a, shared by (n, a-1, a) and (w, n, a): flip to w-(a-1).
      out.a_at = (out.a_at + d - 1) % d;
      flipped = true;
    }
    const size_t path2 = (out.a_at + d - out.b_at) % d;
    // w-b, shared by (n, w, b) and (w, b-1, b): flip to n-(b-1).
    if (path2 + 1 < d && FlipIsConvex(W, at(out.b_at + d - 1), at(out.b_at), N) &&
        InCircle(W, at(out.b_at + d - 1), at(out.b_at), N)) {
      out.b_at = (out.b_at + d - 1) % d;
      flipped = true;
    } else if (path2 > 1 && FlipIsConvex(N, W, at(out.b_at), at(out.b_at + 1)) &&
               InCircle(N, W, at(out.b_at), at(out.b_at + 1))) {
      // n-b, shared by (n, w, b) and (n, b, b+1): flip to w-(b+1).
      out.b_at = (out.b_at + 1) % d;
      flipped = true;
    }
    if (!flipped) break;
  }
  return out;
}

PredictedWings WingsFromGeometry(const RingFrame& f, const Vec3i& u, const Vec3i& v) {
  const size_t d = f.ring.size();
  const Vec2d pu = f.Project(ToDouble(u)), pv = f.Project(ToDouble(v));
  const Vec2d mid = {(pu[0] + pv[0]) / 2, (pu[1] + pv[1]) / 2};
  const Vec2d dir = Sub(pv, pu);
  // score > 0: the ring vertex is nearer the new vertex than w.
  std::vector<double>& work = f.work;
  work.assign(4 * d + 1, 0);
  double* score = work.data();
  double* prefix = work.data() + 2 * d;
  for (size_t t = 0; t < 2 * d; ++t) {
    const Vec2d& x = f.ring_uv[t % d];
    score[t] = (x[0] - mid[0]) * dir[0] + (x[1] - mid[1]) * dir[1];
    prefix[t + 1] = prefix[t] + score[t];
  }
  // A split with wings b = ring[i], a = ring[j] (1 <= j - i <= d - 1) gives
  // the new vertex ring[i+1..j-1] alone, shares the wings and leaves the rest
  // to w. Maximize score(i) + score(j) + 2 * sum(score(i+1..j-1)) =
  // g(j) + f(i) with g(j) = score(j) + 2 prefix(j), f(i) = score(i) -
  // 2 prefix(i+1): a sliding-window maximum of f over i in [j-d+1, j-1],
  // O(d) in all (a monotonic queue: candidate i with f decreasing).
  auto fi = [&](size_t i) { return score[i] - 2 * prefix[i + 1]; };
  std::vector<size_t>& window = f.window;
  window.clear();
  size_t head = 0;
  double best = -1e300;
  size_t best_i = 0, best_j = 1;
  for (size_t j = 1; j < 2 * d; ++j) {
    const size_t i = j - 1;
    if (i < d) {
      while (window.size() > head && fi(window.back()) < fi(i)) window.pop_back();
      window.push_back(i);
    }
    while (window.size() > head && window[head] + d - 1 < j) ++head;
    if (window.size() == head) continue;
    const double value = score[j] + 2 * prefix[j] + fi(window[head]);
    if (value > best) {
      best = value;
      best_i = window[head];
      best_j = j;
    }
  }
  PredictedWings out;
  out.b_at = best_i % d;
  out.a_at = best_j % d;
  out.new_uv = pv;
  return out;
}

Vec2d NewVertexUv(const RingFrame& f, size_t a_at, size_t b_at) {
  const size_t d = f.ring.size();
  const size_t path = (a_at + d - b_at) % d;
  Vec2d mean{0, 0};
  for (size_t s = 0; s <= path; ++s) {
    const Vec2d& p = f.ring_uv[(b_at + s) % d];
    mean[0] += p[0];
    mean[1] += p[1];
  }
  mean[0] /= double(path + 1);
  mean[1] /= double(path + 1);
  return {(f.w_uv[0] + mean[0]) / 2, (f.w_uv[1] + mean[1]) / 2};
}

void PredictGeometry(const RingFrame& f, size_t a_at, size_t b_at, const Vec2d& new_uv,
                     const std::vector<int32_t>& channels, int count, PredictedGeometry* result, double spread) {
  const size_t d = f.ring.size();
  const size_t path = (a_at + d - b_at) % d;
  const size_t dims = 3 + size_t(count);
  // Values per vertex: position then channels; index 0 is w, 1 + k ring[k].
  auto value = [&](size_t vertex, size_t c) -> double {
    if (c < 3) return vertex == 0 ? f.w[c] : f.ring[vertex - 1][c];
    return channels[vertex * size_t(count) + (c - 3)];
  };
  auto weight = [](const Vec2d& from, const Vec2d& to) { return 1.0 / std::max(Distance(from, to), 1e-9); };
  // The new vertex: neighbours ring[b..a] and w.
  std::vector<double>& both = result->scratch;
  both.assign(2 * dims, 0);
  double* nv = both.data();
  double* wv = both.data() + dims;
  double total = weight(new_uv, f.w_uv);
  for (size_t c = 0; c < dims; ++c) nv[c] = total * value(0, c);
  for (size_t s = 0; s <= path; ++s) {
    const size_t k = (b_at + s) % d;
    const double wt = weight(new_uv, f.ring_uv[k]);
    total += wt;
    for (size_t c = 0; c < dims; ++c) nv[c] += wt * value(1 + k, c);
  }
  for (size_t c = 0; c < dims; ++c) nv[c] /= total;
  // w: neighbours ring[a..b] and the new vertex (already updated).
  total = weight(f.w_uv, new_uv);
  for (size_t c = 0; c < dims; ++c) wv[c] = total * nv[c];
  for (size_t s = 0; s <= d - path; ++s) {
    const size_t k = (a_at + s) % d;
    const double wt = weight(f.w_uv, f.ring_uv[k]);
    total += wt;
    for (size_t c = 0; c < dims; ++c) wv[c] += wt * value(1 + k, c);
  }
  for (size_t c = 0; c < dims; ++c) wv[c] /= total;
  // Keep the coarse vertex at their midpoint, the pair in the plane of the
  // ring (an offset along the normal is what moves a surface; the coarse
  // surface is the best guess of the fine one there), and every value
  // within the range of what it was made from.
  double half[3];
  for (int c = 0; c < 3; ++c) half[c] = (nv[c] - wv[c]) / 2 * spread;
  const double along = half[0] * f.normal[0] + half[1] * f.normal[1] + half[2] * f.normal[2];
  for (int c = 0; c < 3; ++c) half[c] -= along * f.normal[c];
  PredictedGeometry& out = *result;
  out.u_channels.resize(size_t(count));
  out.v_channels.resize(size_t(count));
  for (size_t c = 0; c < dims; ++c) {
    const double coarse = value(0, c);
    double lo = coarse, hi = coarse;
    if (c < 3) {
      for (size_t k = 0; k < d; ++k) {
        lo = std::min(lo, f.ring[k][c]);
        hi = std::max(hi, f.ring[k][c]);
      }
    } else {
      const int32_t* x = channels.data() + size_t(count) + (c - 3);
      for (size_t k = 0; k < d; ++k, x += count) {
        lo = std::min(lo, double(*x));
        hi = std::max(hi, double(*x));
      }
    }
    const double h = c < 3 ? half[c] : (nv[c] - wv[c]) / 2 * spread;
    const int32_t u = RoundHalfAway(std::clamp(coarse - h, lo, hi));
    const int32_t v = RoundHalfAway(std::clamp(coarse + h, lo, hi));
    if (c < 3) {
      out.u[c] = u;
      out.v[c] = v;
    } else {
      out.u_channels[c - 3] = u;
      out.v_channels[c - 3] = v;
    }
  }
}

}  // namespace meshstream
