// CSG ray casting by interval lists (Roth 1982). Hand-written: neither PCL, OpenCV nor any
// Debian package offers exact ray-CSG with analytic normals; a mesh ray caster would put
// tessellation error (microns on a 20 mm bore) into the ground truth.

#include "mlp/sim/scene.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace mlp::sim {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

SurfaceHit Hit(double t, const Vec3& normal, double reflectance) {
  return SurfaceHit{t, normal, reflectance, Gloss{}};
}

class Halfspace : public Solid {
 public:
  Halfspace(const Vec3& p, const Vec3& n, double refl) : p_(p), n_(n.normalized()), refl_(refl) {}
  void Spans(const Ray& ray, SpanList* out) const override {
    const double s = n_.dot(ray.origin - p_), ds = n_.dot(ray.direction);
    if (ds == 0.0) {
      if (s <= 0.0)
        out->push_back({Hit(-kInf, Vec3::Zero(), refl_), Hit(kInf, Vec3::Zero(), refl_)});
      return;
    }
    const double t0 = -s / ds;
    if (ds > 0.0) {
      out->push_back({Hit(-kInf, Vec3::Zero(), refl_), Hit(t0, n_, refl_)});
    } else {
      out->push_back({Hit(t0, n_, refl_), Hit(kInf, Vec3::Zero(), refl_)});
    }
  }

 private:
  Vec3 p_, n_;
  double refl_;
};

class Box : public Solid {
 public:
  Box(const Vec3& lo, const Vec3& hi, double refl) : lo_(lo), hi_(hi), refl_(refl) {}
  void Spans(const Ray& ray, SpanList* out) const override {
    double t_in = -kInf, t_out = kInf;
    int axis_in = -1, axis_out = -1;
    double sign_in = 0.0, sign_out = 0.0;
    for (int k = 0; k < 3; ++k) {
      const double o = ray.origin(k), d = ray.direction(k);
      if (d == 0.0) {
        if (o < lo_(k) || o > hi_(k)) return;
        continue;
      }
      double t0 = (lo_(k) - o) / d, t1 = (hi_(k) - o) / d;
      double s0 = -1.0, s1 = 1.0;  // outward normal sign of the face met at t0, t1
      if (t0 > t1) std::swap(t0, t1), std::swap(s0, s1);
      if (t0 > t_in) t_in = t0, axis_in = k, sign_in = s0;
      if (t1 < t_out) t_out = t1, axis_out = k, sign_out = s1;
    }
    if (t_in >= t_out || axis_in < 0 || axis_out < 0) return;
    out->push_back({Hit(t_in, sign_in * Vec3::Unit(axis_in), refl_),
                    Hit(t_out, sign_out * Vec3::Unit(axis_out), refl_)});
  }

 private:
  Vec3 lo_, hi_;
  double refl_;
};

class Sphere : public Solid {
 public:
  Sphere(const Vec3& c, double r, double refl) : c_(c), r_(r), refl_(refl) {}
  void Spans(const Ray& ray, SpanList* out) const override {
    const Vec3 q = ray.origin - c_;
    const double b = q.dot(ray.direction), c = q.squaredNorm() - r_ * r_;
    const double disc = b * b - c;
    if (disc <= 0.0) return;
    const double root = std::sqrt(disc);
    // Stable roots (no cancellation when |b| ~ root): t0 t1 = c.
    const double t_far = b > 0.0 ? -b - root : -b + root;
    double t0 = c / t_far, t1 = t_far;
    if (t0 > t1) std::swap(t0, t1);
    out->push_back({Hit(t0, (q + t0 * ray.direction) / r_, refl_),
                    Hit(t1, (q + t1 * ray.direction) / r_, refl_)});
  }

 private:
  Vec3 c_;
  double r_, refl_;
};

// Capped solid of revolution whose radius varies linearly along the axis: cylinder (k = 0) or
// cone frustum. Inside: |x_perp|^2 <= (r0 + k h)^2 and 0 <= h <= length.
class Revolution : public Solid {
 public:
  Revolution(const Vec3& base, const Vec3& axis, double length, double r0, double r1, double refl)
      : base_(base),
        axis_(axis.normalized()),
        length_(length),
        r0_(r0),
        k_((r1 - r0) / length),
        refl_(refl) {}

  void Spans(const Ray& ray, SpanList* out) const override {
    const Vec3 q = ray.origin - base_;
    const double h0 = q.dot(axis_), dh = ray.direction.dot(axis_);
    const Vec3 q_perp = q - h0 * axis_, d_perp = ray.direction - dh * axis_;
    const double r_at0 = r0_ + k_ * h0;
    const double a = d_perp.squaredNorm() - k_ * k_ * dh * dh;
    const double b = 2.0 * (q_perp.dot(d_perp) - k_ * dh * r_at0);
    const double c = q_perp.squaredNorm() - r_at0 * r_at0;
    SpanList mantle;
    MantleSpans(ray, a, b, c, &mantle);
    // The slab 0 <= h <= length, with the end caps as its faces.
    SpanList slab;
    if (dh == 0.0) {
      if (h0 >= 0.0 && h0 <= length_)
        slab.push_back({Hit(-kInf, Vec3::Zero(), refl_), Hit(kInf, Vec3::Zero(), refl_)});
    } else {
      double t0 = -h0 / dh, t1 = (length_ - h0) / dh;
      Vec3 n0 = -axis_, n1 = axis_;
      if (t0 > t1) std::swap(t0, t1), std::swap(n0, n1);
      slab.push_back({Hit(t0, n0, refl_), Hit(t1, n1, refl_)});
    }
    IntersectLists(mantle, slab, out);
  }

 private:
  Vec3 NormalAt(const Vec3& x) const {
    const Vec3 q = x - base_;
    const double h = q.dot(axis_);
    const Vec3 perp = q - h * axis_;
    return (perp - k_ * (r0_ + k_ * h) * axis_).normalized();
  }

  void MantleSpans(const Ray& ray, double a, double b, double c, SpanList* out) const {
    auto hit = [&](double t) { return Hit(t, NormalAt(ray.origin + t * ray.direction), refl_); };
    const double scale = std::max({std::abs(a), std::abs(b), std::abs(c), 1e-300});
    if (std::abs(a) <= 1e-14 * scale) {  // linear: ray parallel to a generatrix (or the axis)
      if (b == 0.0) {
        if (c <= 0.0)
          out->push_back({Hit(-kInf, Vec3::Zero(), refl_), Hit(kInf, Vec3::Zero(), refl_)});
        return;
      }
      const double t = -c / b;
      if (b > 0.0)
        out->push_back({Hit(-kInf, Vec3::Zero(), refl_), hit(t)});
      else
        out->push_back({hit(t), Hit(kInf, Vec3::Zero(), refl_)});
      return;
    }
    const double disc = b * b - 4.0 * a * c;
    if (disc <= 0.0) {
      if (a < 0.0)
        out->push_back({Hit(-kInf, Vec3::Zero(), refl_), Hit(kInf, Vec3::Zero(), refl_)});
      return;
    }
    const double qq = -0.5 * (b + std::copysign(std::sqrt(disc), b));
    double t0 = qq / a, t1 = c / qq;
    if (t0 > t1) std::swap(t0, t1);
    if (a > 0.0) {
      out->push_back({hit(t0), hit(t1)});
    } else {  // a double cone seen from outside both nappes: inside before t0 and after t1
      out->push_back({Hit(-kInf, Vec3::Zero(), refl_), hit(t0)});
      out->push_back({hit(t1), Hit(kInf, Vec3::Zero(), refl_)});
    }
  }

  static void IntersectLists(const SpanList& a, const SpanList& b, SpanList* out);

  Vec3 base_, axis_;
  double length_, r0_, k_, refl_;
};

enum class Op { kUnion, kIntersection, kDifference };

// Sweep over the boundary events of two span lists; emits the spans where op(in_a, in_b) holds.
// A surface that bounds the result from the subtracted solid gets that solid's normal reversed.
void Combine(const SpanList& a, const SpanList& b, Op op, SpanList* out) {
  struct Event {
    SurfaceHit hit;
    bool from_a, enter;
    size_t order;
  };
  boost::container::small_vector<Event, 16> events;
  for (const Span& s : a)
    events.push_back({s.in, true, true, 0}), events.push_back({s.out, true, false, 0});
  for (const Span& s : b)
    events.push_back({s.in, false, true, 0}), events.push_back({s.out, false, false, 0});
  // Stable by the events' order of listing, without std::stable_sort's heap buffer.
  for (size_t i = 0; i < events.size(); ++i) events[i].order = i;
  std::sort(events.begin(), events.end(), [](const Event& x, const Event& y) {
    return x.hit.t < y.hit.t || (x.hit.t == y.hit.t && x.order < y.order);
  });
  bool in_a = false, in_b = false, inside = false;
  SurfaceHit start;
  for (const Event& e : events) {
    (e.from_a ? in_a : in_b) = e.enter;
    const bool now = op == Op::kUnion          ? (in_a || in_b)
                     : op == Op::kIntersection ? (in_a && in_b)
                                               : (in_a && !in_b);
    if (now && !inside) {
      start = e.hit;
      if (!e.enter) start.normal = -start.normal;  // entered by leaving the subtracted solid
      inside = true;
    } else if (!now && inside) {
      SurfaceHit end = e.hit;
      if (e.enter) end.normal = -end.normal;  // left by entering the subtracted solid
      if (end.t > start.t) out->push_back({start, end});
      inside = false;
    }
  }
}

void Revolution::IntersectLists(const SpanList& a, const SpanList& b, SpanList* out) {
  Combine(a, b, Op::kIntersection, out);
}

class Compound : public Solid {
 public:
  Compound(Op op, SolidPtr first, std::vector<SolidPtr> rest)
      : op_(op), first_(std::move(first)), rest_(std::move(rest)) {}
  void Spans(const Ray& ray, SpanList* out) const override {
    SpanList acc, next, combined;
    first_->Spans(ray, &acc);
    for (const SolidPtr& s : rest_) {
      next.clear(), combined.clear();
      s->Spans(ray, &next);
      Combine(acc, next, op_, &combined);
      acc.swap(combined);
    }
    out->insert(out->end(), acc.begin(), acc.end());
  }
  bool Glossy() const override {
    return first_->Glossy() ||
           std::any_of(rest_.begin(), rest_.end(), [](const SolidPtr& s) { return s->Glossy(); });
  }

 private:
  Op op_;
  SolidPtr first_;
  std::vector<SolidPtr> rest_;
};

class Finish : public Solid {
 public:
  Finish(SolidPtr solid, const Gloss& gloss, double diffuse)
      : solid_(std::move(solid)), gloss_(gloss), diffuse_(diffuse) {}
  void Spans(const Ray& ray, SpanList* out) const override {
    const size_t first = out->size();
    solid_->Spans(ray, out);
    for (size_t i = first; i < out->size(); ++i) {
      for (SurfaceHit* h : {&(*out)[i].in, &(*out)[i].out}) {
        h->gloss = gloss_;
        if (diffuse_ >= 0.0) h->reflectance = diffuse_;
      }
    }
  }
  bool Glossy() const override { return gloss_.specular_f0 > 0.0; }

 private:
  SolidPtr solid_;
  Gloss gloss_;
  double diffuse_;
};

SolidPtr MakeCompound(Op op, std::vector<SolidPtr> parts) {
  if (parts.empty()) throw SceneError("scene: a union or intersection needs at least one solid");
  SolidPtr first = parts.front();
  parts.erase(parts.begin());
  return std::make_shared<Compound>(op, std::move(first), std::move(parts));
}

}  // namespace

SolidPtr MakeHalfspace(const Vec3& point, const Vec3& normal, double reflectance) {
  return std::make_shared<Halfspace>(point, normal, reflectance);
}
// A box in its own frame whose face reflectance follows a chessboard.
class Chessboard : public Solid {
 public:
  Chessboard(
      const Pose3& mcs_from_board, int cols, int rows, double square, double light, double dark)
      : board_from_mcs_(mcs_from_board.inverse()),
        rotation_(mcs_from_board.linear()),
        box_(Vec3(-square, -square, -kThicknessMm),
             Vec3((cols + 2) * square, (rows + 2) * square, 0.0),
             light),
        cols_(cols),
        rows_(rows),
        square_(square),
        light_(light),
        dark_(dark) {}
  void Spans(const Ray& ray, SpanList* out) const override {
    const Ray local{board_from_mcs_ * ray.origin, board_from_mcs_.linear() * ray.direction};
    SpanList spans;
    box_.Spans(local, &spans);
    for (Span& s : spans) {
      for (SurfaceHit* h : {&s.in, &s.out}) {
        h->reflectance = Reflectance(local.origin + h->t * local.direction);
        h->normal = rotation_ * h->normal;
      }
      out->push_back(s);
    }
  }

 private:
  static constexpr double kThicknessMm = 5.0;
  double Reflectance(const Vec3& p) const {
    const int i = static_cast<int>(std::floor(p.x() / square_));
    const int j = static_cast<int>(std::floor(p.y() / square_));
    const bool in_board = i >= 0 && i <= cols_ && j >= 0 && j <= rows_;
    return in_board && ((i + j) % 2 != 0) ? dark_ : light_;
  }
  Pose3 board_from_mcs_;
  Eigen::Matrix3d rotation_;
  Box box_;
  int cols_, rows_;
  double square_, light_, dark_;
};

SolidPtr MakeChessboard(const Pose3& mcs_from_board,
                        int inner_cols,
                        int inner_rows,
                        double square_mm,
                        double light_reflectance,
                        double dark_reflectance) {
  if (inner_cols < 2 || inner_rows < 2 || !(square_mm > 0))
    throw SceneError("chessboard: at least 2 x 2 inner corners and a square > 0 mm");
  return std::make_shared<Chessboard>(mcs_from_board, inner_cols, inner_rows, square_mm,
                                      light_reflectance, dark_reflectance);
}

SolidPtr MakeBox(const Vec3& lo, const Vec3& hi, double reflectance) {
  return std::make_shared<Box>(lo, hi, reflectance);
}
SolidPtr MakeSphere(const Vec3& center, double radius, double reflectance) {
  return std::make_shared<Sphere>(center, radius, reflectance);
}
SolidPtr MakeRevolution(const Vec3& base,
                        const Vec3& axis,
                        double length,
                        double radius_base,
                        double radius_top,
                        double reflectance) {
  return std::make_shared<Revolution>(base, axis, length, radius_base, radius_top, reflectance);
}
SolidPtr MakeFinish(SolidPtr solid, const Gloss& gloss, double diffuse) {
  if (!(gloss.specular_f0 >= 0.0 && gloss.specular_f0 <= 1.0) ||
      !(gloss.roughness >= 0.005 && gloss.roughness <= 1.0) || !(diffuse <= 1.0)) {
    throw SceneError("finish: specular_f0 in [0, 1], roughness in [0.005, 1], diffuse <= 1");
  }
  return std::make_shared<Finish>(std::move(solid), gloss, diffuse);
}
SolidPtr MakeUnion(std::vector<SolidPtr> parts) {
  return MakeCompound(Op::kUnion, std::move(parts));
}
SolidPtr MakeIntersection(std::vector<SolidPtr> parts) {
  return MakeCompound(Op::kIntersection, std::move(parts));
}
SolidPtr MakeDifference(SolidPtr a, std::vector<SolidPtr> b) {
  return std::make_shared<Compound>(Op::kDifference, std::move(a), std::move(b));
}

std::optional<SurfaceHit> Scene::FirstHit(const Ray& ray, double t_min) const {
  SpanList spans;
  workpiece->Spans(ray, &spans);
  for (const Span& s : spans) {
    if (s.in.t > t_min && std::isfinite(s.in.t)) return s.in;
    if (s.in.t <= t_min && s.out.t > t_min) return std::nullopt;  // the ray starts inside
  }
  return std::nullopt;
}

bool Scene::Blocked(const Vec3& from, const Vec3& to, double margin_mm) const {
  const Vec3 d = to - from;
  const double length = d.norm();
  if (length <= 2.0 * margin_mm) return false;
  const Ray ray{from, d / length};
  SpanList spans;
  workpiece->Spans(ray, &spans);
  for (const Span& s : spans) {
    if (s.out.t > margin_mm && s.in.t < length - margin_mm) return true;
  }
  return false;
}

}  // namespace mlp::sim
