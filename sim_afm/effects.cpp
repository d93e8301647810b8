// The per-sample effects a scene can name, and the registry that builds them
// (piezo_hysteresis and piezo_creep: the scanner's, piezo.hpp; scan_artefacts:
// the scans', scan_artefacts.hpp).
#include <cmath>
#include <functional>
#include <map>

#include "world.hpp"
#include "world_internal.hpp"

namespace afm::sim {

namespace {

// White noise on S_n and S_l. Default level: the lever's thermal noise,
// <delta^2> = kT / k_n and <twist^2> = kT / k_theta, as volts.
class PhotodiodeNoise : public SampleEffect {
public:
    PhotodiodeNoise(const Scene &s, const Lever &lever) : SampleEffect("photodiode_noise")
    {
        const double kT = kBoltzmann_nN_nm_per_K * s.temperature_K;
        sn_rms_ = s.photodiode_noise_V > 0 ? s.photodiode_noise_V : std::sqrt(kT / lever.spring) / lever.deflection;
        sl_rms_ = s.photodiode_noise_V > 0 ? s.photodiode_noise_V : std::sqrt(kT / lever.ktheta) / lever.Kl;
    }
    void apply(World &w, double &sn, double &sl) override
    {
        sn += sn_rms_ * gauss_(w.rng());
        sl += sl_rms_ * gauss_(w.rng());
    }

private:
    double sn_rms_, sl_rms_;
    std::normal_distribution<double> gauss_{0.0, 1.0};
};

// Thermal drift of the sample against the scanner (section 10): a linear
// drift plus a random walk, both per minute.
class ThermalDrift : public SampleEffect {
public:
    ThermalDrift(const Scene &s, double dt) : SampleEffect("thermal_drift")
    {
        step_ = Eigen::Vector2d(s.drift_nm_per_min.x, s.drift_nm_per_min.y) * dt / 60.0;
        walk_ = s.drift_walk_nm_per_sqrt_min * std::sqrt(dt / 60.0);
    }
    void apply(World &w, double &, double &) override
    {
        w.add_drift(step_ + walk_ * Eigen::Vector2d(gauss_(w.rng()), gauss_(w.rng())));
    }

private:
    Eigen::Vector2d step_;
    double walk_;
    std::normal_distribution<double> gauss_{0.0, 1.0};
};

// Nanolithography (section 9): the tip cuts a trench while the load exceeds
// the threshold; the World keeps the trenches and images them.
class Lithography : public SampleEffect {
public:
    Lithography() : SampleEffect("lithography") {}
    void apply(World &w, double &, double &) override { w.engrave(); }
};

// The deflection signal's zero drifts (z_drift, physics.md section 17.4):
// d(t) = rate t + walk W(t), nm of deflection (W a Wiener process, per
// minute). The signal reads d more than the lever bends; the z servo holds
// the signal at the set point, so the true load is k_n d below it
// (World::set_deflection_zero_nm) while S_n reads the set point's volts.
class ZDrift : public SampleEffect {
public:
    ZDrift(const Scene &s, const Lever &lever) : SampleEffect("z_drift"), volts_per_nm_(1.0 / lever.deflection)
    {
        const double dt = 1.0 / s.sample_rate_hz;
        step_nm_ = s.instrument.z_drift_nm_per_min * dt / 60.0;
        walk_nm_ = s.instrument.z_drift_walk_nm_per_sqrt_min * std::sqrt(dt / 60.0);
    }
    void apply(World &w, double &sn, double &) override
    {
        sn += zero_nm_ * volts_per_nm_;   // the zero this sample's mechanics ran with
        zero_nm_ += step_nm_ + (walk_nm_ > 0 ? walk_nm_ * gauss_(w.rng()) : 0.0);
        w.set_deflection_zero_nm(zero_nm_);
    }

private:
    double volts_per_nm_, step_nm_ = 0, walk_nm_ = 0, zero_nm_ = 0;
    std::normal_distribution<double> gauss_{0.0, 1.0};
};

using Factory = std::function<std::unique_ptr<SampleEffect>(const Scene &, const Lever &)>;

const std::map<std::string, Factory> &registry()
{
    static const std::map<std::string, Factory> r = {
        {"photodiode_noise", [](const Scene &s, const Lever &l) { return std::make_unique<PhotodiodeNoise>(s, l); }},
        {"lithography", [](const Scene &, const Lever &) { return std::make_unique<Lithography>(); }},
        {"thermal_drift", [](const Scene &s, const Lever &) { return std::make_unique<ThermalDrift>(s, 1.0 / s.sample_rate_hz); }},
        {"z_drift", [](const Scene &s, const Lever &l) { return std::make_unique<ZDrift>(s, l); }},
    };
    return r;
}

}  // namespace

std::vector<std::unique_ptr<SampleEffect>> build_sample_effects(const Scene &s, const Lever &lever)
{
    std::vector<std::unique_ptr<SampleEffect>> out;
    for (const auto &name : s.effects) {
        auto it = registry().find(name);
        if (it != registry().end()) out.push_back(it->second(s, lever));
    }
    return out;
}

}  // namespace afm::sim
