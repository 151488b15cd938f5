#include "common/stats/integrate.h"

#include <cmath>

namespace alphorn::stats {

namespace {

double simpsonStep(const std::function<double(double)>& f, double a, double b, double fa, double fm,
                   double fb, double whole, double eps, int depth) {
    const double m = 0.5 * (a + b);
    const double lm = 0.5 * (a + m), rm = 0.5 * (m + b);
    const double flm = f(lm), frm = f(rm);
    const double left = (m - a) / 6.0 * (fa + 4.0 * flm + fm);
    const double right = (b - m) / 6.0 * (fm + 4.0 * frm + fb);
    const double both = left + right;
    // Richardson: the error of the refined estimate is about (both - whole) / 15.
    if (depth <= 0 || std::abs(both - whole) <= 15.0 * eps) return both + (both - whole) / 15.0;
    return simpsonStep(f, a, m, fa, flm, fm, left, 0.5 * eps, depth - 1) +
           simpsonStep(f, m, b, fm, frm, fb, right, 0.5 * eps, depth - 1);
}

}  // namespace

double adaptiveSimpson(const std::function<double(double)>& f, double a, double b, double eps,
                       int maxDepth) {
    if (!(b > a)) return 0.0;
    // Start from four panels rather than one: a single Simpson panel can miss a narrow peak
    // entirely and then report a converged zero.
    const int panels = 4;
    const double h = (b - a) / panels;
    double total = 0.0;
    double fa = f(a);
    for (int i = 0; i < panels; ++i) {
        const double x0 = a + i * h, x1 = i + 1 == panels ? b : a + (i + 1) * h;
        const double xm = 0.5 * (x0 + x1);
        const double fm = f(xm), fb = f(x1);
        const double whole = (x1 - x0) / 6.0 * (fa + 4.0 * fm + fb);
        total += simpsonStep(f, x0, x1, fa, fm, fb, whole, eps / panels, maxDepth);
        fa = fb;
    }
    return total;
}

double adaptiveSimpson2D(const std::function<double(double, double)>& f, double x0, double y0,
                         double x1, double y1, double eps, int maxDepth) {
    const double width = x1 - x0;
    if (!(width > 0.0) || !(y1 > y0)) return 0.0;
    auto inner = [&](double x) {
        return adaptiveSimpson([&](double y) { return f(x, y); }, y0, y1, eps / width, maxDepth);
    };
    return adaptiveSimpson(inner, x0, x1, eps, maxDepth);
}

}  // namespace alphorn::stats
