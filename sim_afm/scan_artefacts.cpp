// Scan artefacts: line offsets, the z servo's lag, the scanner's bow
// (scan_artefacts.hpp).
#include "scan_artefacts.hpp"

#include <cmath>

namespace afm::sim {

namespace {
// Keeps the artefacts' draws apart from every other stream seeded by the scene.
constexpr uint64_t kStreamSalt = 0x5ca4a27e1ac75ull;
}  // namespace

ScanArtefacts::ScanArtefacts(const Scene &s)
    : offset_rms_nm_(s.instrument.line_offset_rms_nm), lag_nm_(s.instrument.servo_lag_nm), sag_nm_(s.instrument.bow_sag_nm),
      cx_(s.field_center_nm.x), cy_(s.field_center_nm.y), half_(s.field_nm / 2), rng_(s.seed ^ kStreamSalt)
{
}

double ScanArtefacts::bow_nm(double x, double y) const
{
    const double u = (x - cx_) / half_, v = (y - cy_) / half_;
    return -sag_nm_ * (u * u + v * v);
}

void ScanArtefacts::apply(double x0, double dx, double y, int n, double *height_nm, double *error_nm)
{
    const double offset = offset_rms_nm_ * gauss_(rng_);
    const double follow = lag_nm_ > 0 ? 1.0 - std::exp(-std::fabs(dx) / lag_nm_) : 1.0;
    double z = n > 0 ? height_nm[0] : 0.0;
    for (int i = 0; i < n; ++i) {
        z += follow * (height_nm[i] - z);
        error_nm[i] = height_nm[i] - z;
        height_nm[i] = z + offset + bow_nm(x0 + i * dx, y);
    }
}

}  // namespace afm::sim
