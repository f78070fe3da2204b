// est::blob::section_stable against the poles computed in double precision (exact for these
// fields: k 2^-n has at most 16 significant bits): never a section with a pole on or outside
// the unit circle accepted; every section whose poles lie inside by more than 1e-7 accepted.
// Cases: random fields (direct and delta form) and sections quantised from poles drawn near
// the unit circle (radius 0.98..1.02, real pairs and complex pairs), as the quantizer stores them.
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include "check.h"
#include "model_blob.h"

namespace {

struct Section {
  uint8_t fl, n1, n2;
  int16_t k1, k2;
};

// Feedback weights c1, c2 (y = ... + c1 y1 + c2 y2) as the format defines them.
void weights(const Section& s, double* c1, double* c2) {
  const double r1 = ldexp(s.k1, -s.n1), r2 = ldexp(s.k2, -s.n2);
  if (s.fl & est::blob::kSecDelta) {
    *c1 = 2 + r1;
    *c2 = -1 - r1 + r2;
  } else {
    *c1 = ((s.fl >> 2) & 7) - 2 + r1;
    *c2 = ((s.fl >> 5) & 3) - 1 + r2;
  }
}

// Largest pole magnitude of z^2 - c1 z - c2.
double pole_radius(double c1, double c2) {
  const double disc = c1 * c1 + 4 * c2;
  if (disc >= 0) {
    const double s = sqrt(disc);
    return fmax(fabs((c1 + s) / 2), fabs((c1 - s) / 2));
  }
  return sqrt(-c2);  // complex pair: |p|^2 = -c2
}

// The section the quantizer would store for weights c1, c2: integer base plus a residue in
// 2^-n steps with n as large as 16 bits allow (direct form), or the delta form near z = 1.
Section quantised(double c1, double c2, bool delta) {
  Section s = {};
  if (delta) {
    s.fl = est::blob::kSecDelta | uint8_t(2 << 2) | uint8_t(1 << 5);
    const double alpha1 = c1 - 2, alpha0 = -(1 - c1 - c2);  // k1' = c1 - 2, k2' = -A(1)
    s.n1 = 16;
    while (s.n1 < 47 && fabs(ldexp(alpha1, s.n1 + 1)) < 32767) ++s.n1;
    s.n2 = 16;
    while (s.n2 < 47 && fabs(ldexp(alpha0, s.n2 + 1)) < 32767) ++s.n2;
    s.k1 = int16_t(lround(ldexp(alpha1, s.n1)));
    s.k2 = int16_t(lround(ldexp(alpha0, s.n2)));
    return s;
  }
  const double m1 = round(c1), m2 = round(c2);
  s.fl = uint8_t(int(m1 + 2) << 2 | int(m2 + 1) << 5);
  const double r1 = c1 - m1, r2 = c2 - m2;
  s.n1 = 16;
  while (s.n1 < 47 && fabs(ldexp(r1, s.n1 + 1)) < 32767) ++s.n1;
  s.n2 = 16;
  while (s.n2 < 47 && fabs(ldexp(r2, s.n2 + 1)) < 32767) ++s.n2;
  s.k1 = int16_t(lround(ldexp(r1, s.n1)));
  s.k2 = int16_t(lround(ldexp(r2, s.n2)));
  return s;
}

double uniform(double lo, double hi) { return lo + (hi - lo) * (rand() / (RAND_MAX + 1.0)); }

int g_accepted_unstable = 0, g_refused_clear = 0, g_cases = 0, g_near = 0;

void check(const Section& s) {
  double c1, c2;
  weights(s, &c1, &c2);
  const double radius = pole_radius(c1, c2);
  const bool ok = est::blob::section_stable(s.fl, s.n1, s.n2, s.k1, s.k2);
  ++g_cases;
  if (fabs(radius - 1) < 1e-3) ++g_near;
  g_accepted_unstable += ok && radius >= 1;
  CHECK_MSG(!(ok && radius >= 1), "accepted a pole at |z| = %.12f (fl %02x n %u %u k %d %d)", radius, s.fl, s.n1, s.n2,
            s.k1, s.k2);
  // Refusing a section inside the circle is allowed only within the stated margins: the
  // delta form's 1 - a2 and every direct-form condition are decided to 2^-27.
  const double a1c = 1 - c1 - c2, am1 = 1 + c1 - c2, a2c = 1 + c2;
  const double margin = fmin(fmin(fabs(a1c), fabs(am1)), fabs(a2c));
  g_refused_clear += !ok && radius < 1 && margin > 1e-7;
  CHECK_MSG(!(!ok && radius < 1 && margin > 1e-7), "refused a section with poles at |z| = %.9f, margin %.3g", radius,
            margin);
}

}  // namespace

int main() {
  srand(20260);
  // Random fields: every flag combination the format allows.
  for (int i = 0; i < 200000; ++i) {
    Section s;
    const bool delta = rand() % 4 == 0;
    s.fl = delta ? uint8_t(est::blob::kSecDelta | 2 << 2 | 1 << 5) : uint8_t((rand() % 5) << 2 | (rand() % 3) << 5);
    s.n1 = uint8_t(16 + rand() % 32);
    s.n2 = uint8_t(16 + rand() % 32);
    s.k1 = int16_t(rand() % 65536 - 32768);
    s.k2 = int16_t(rand() % 65536 - 32768);
    check(s);
  }
  // Edge residues: +-1/2 and 0 in every combination of bases.
  const int16_t ks[] = {-32768, -1, 0, 1, 32767};
  for (int m1 = 0; m1 < 5; ++m1)
    for (int m2 = 0; m2 < 3; ++m2)
      for (int16_t k1 : ks)
        for (int16_t k2 : ks) check(Section{uint8_t(m1 << 2 | m2 << 5), 16, 16, k1, k2});
  // Quantised from poles near the unit circle.
  for (int i = 0; i < 200000; ++i) {
    const double r = uniform(0.98, 1.02) + (rand() % 3 == 0 ? uniform(-1e-6, 1e-6) : 0.0);
    double c1, c2;
    if (rand() % 2) {  // complex pair r e^{+-j theta}
      const double th = uniform(0.001, 3.14);
      c1 = 2 * r * cos(th);
      c2 = -r * r;
    } else {  // real pair r, q
      const double q = uniform(-1.0, 1.0) * (rand() % 2 ? 1.0 : r);
      const double p = rand() % 2 ? r : -r;
      c1 = p + q;
      c2 = -p * q;
    }
    if (fabs(c1) > 2.49 || fabs(c2) > 1.49) continue;
    const bool delta = c1 > 1.51 && fabs(c1 - 2) < 0.49 && fabs(1 - c1 - c2) < 0.49;
    check(quantised(c1, c2, delta));
  }
  printf(
      "section_stable: %d sections (%d with a pole within 1e-3 of the circle): %d unstable accepted, "
      "%d clearly stable refused\n",
      g_cases, g_near, g_accepted_unstable, g_refused_clear);
  printf("%s: %d checks, %d failures\n", __FILE__, g_checks, g_failures);
  return g_failures ? 1 : 0;
}
