// The planner's instrument-facing core (planner.hpp): the scene's sites, the tip's
// moves, local scans and fixes, cuts, and run(): cuts, particles, rods.
// Its stages live beside it: push_geometry.cpp, planner_particles.cpp,
// planner_rods.cpp.

#include "planner.hpp"

extern "C" {
#include "fw_board.h"
#include "fw_units.h"
#include "fw_wire.h"
}

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cmath>
#include <deque>
#include <sstream>

#include "card_setup.hpp"
#include "fidelity.hpp"
#include "pattern.hpp"
#include "planner_internal.hpp"
#include "profile.hpp"

namespace afm {

Planner::Planner(const Scene &s) : s_(s), sites_(target_sites(s)), stroke_nm_(kStrokeStart_nm)
{
    if (const std::string why = targets_refusal(s); !why.empty()) throw PlanError(why);
    if (!s.wires.empty()) {
        const CardSetup card(s);
        const fw_card_config_t &c = card.config();
        if (fw_wire_tip_init(&wire_tip_, c.tip_radius_pm, c.tip_half_angle_mdeg, c.wire_friction_pn_per_um,
                             c.wire_mu_ppm, 0) != FW_OK)
            throw PlanError("the card refuses the rods' tip: " + card_refusal(s));
    }
}

Vec2 Planner::drift() const { return {model_->drift_nm[0], model_->drift_nm[1]}; }

const particle_t *Planner::particle(int id) const
{
    for (const auto &p : model_->particles)
        if (p.id == id) return &p;
    return nullptr;
}

PushGeometry Planner::geometry(double r) const
{
    PushGeometry g;
    g.r = r;
    g.tip_r = s_.probe.tip_radius_nm;
    g.approach_nm = s_.op.plan.approach_nm;
    g.clearance_nm = s_.op.plan.clearance_nm;
    // The lever's axis x_C in frame A, as the firmware turns it.
    q30_t axis[2];
    fw_board_lever_axis_q30(fwu_mdeg_from_deg(s_.probe.scan_angle_deg), axis);
    g.lever_axis = {fwu_from_q30(axis[0]), fwu_from_q30(axis[1])};
    g.min_lever_angle_deg = kMinLeverAngle_deg;
    return g;
}

std::vector<Disc> Planner::obstacles(int except_id) const
{
    std::vector<Disc> out;
    const Vec2 d = drift();
    for (const auto &p : model_->particles)
        if (p.id != except_id) out.push_back({Vec2{p.x_nm, p.y_nm} - d, p.radius_nm, p.id});
    // A rod: discs of its radius along its axis, half a diameter apart.
    for (const auto &w : model_->wires)
        for (int i = 0; i + 1 < w.n; ++i) {
            const Vec2 a = Vec2{w.x_nm[i], w.y_nm[i]} - d, b = Vec2{w.x_nm[i + 1], w.y_nm[i + 1]} - d;
            const int k = std::max(1, static_cast<int>(std::ceil(norm(b - a) / (w.diameter_nm / 2))));
            for (int j = 0; j <= k; ++j) out.push_back({a + (static_cast<double>(j) / k) * (b - a), w.diameter_nm / 2, -w.id});
        }
    return out;
}

void Planner::hold(int blocks)
{
    for (int i = 0; i < blocks; ++i) model_ = &instrument_->block({tip_, engaged_, load_nN_});
}

void Planner::wait_s(double s) { hold(static_cast<int>(std::lround(s * s_.block_hz))); }

void Planner::cut(const CutSpec &c)
{
    const PlanSpec &ps = s_.op.plan;
    if (engaged_) travel(tip_, false, ps.travel_speed_nm_per_s);
    travel(c.from_nm, false, ps.travel_speed_nm_per_s);
    travel(tip_, true, ps.speed_nm_per_s);   // land at the operator's load
    load_nN_ = c.load_nN;
    hold(kLandBlocks);                       // pressed in before it moves
    travel(c.to_nm, true, ps.speed_nm_per_s);
    load_nN_ = 0;
    hold(kLandBlocks);                       // back to the light load before lifting
    travel(tip_, false, ps.travel_speed_nm_per_s);
    ++rep_.cuts;
    rep_.cuts_done_s = instrument_->time_s();
}

void Planner::travel(Vec2 to, bool engaged, double speed)
{
    if (engaged != engaged_) {
        engaged_ = engaged;
        hold(kLandBlocks);
    }
    // Lifted, never along the lever's axis: the card flags a blind push
    // (FW_FLAG_BLIND_PUSH) whenever its direction of motion lies in that
    // cone and the apex is over an object it models, lifted or not, and a
    // local scan holds the tip over its particle with the direction of
    // the move that brought it there. At a corner the tip stops a block,
    // so that the card's direction turns from one leg to the next without
    // passing through the axis.
    const std::vector<Vec2> route = engaged_ ? std::vector<Vec2>{to} : lifted_route(tip_, to, geometry(0), s_.field_center_nm);
    const double step = speed / s_.block_hz;
    for (std::size_t k = 0; k < route.size(); ++k) {
        if (k > 0) hold(1);
        while (norm(route[k] - tip_) > 1e-9) {
            const Vec2 d = route[k] - tip_;
            tip_ = norm(d) <= step ? route[k] : tip_ + step * unit(d);
            model_ = &instrument_->block({tip_, engaged_, load_nN_});
        }
    }
}

bool Planner::scan_at(int id, Vec2 around, Vec2 *found)
{
    const PlanSpec &ps = s_.op.plan;
    if (engaged_) travel(tip_, false, ps.travel_speed_nm_per_s);
    const particle_t *p = particle(id);
    if (!p) return false;
    const double r = p->radius_nm;
    const TipShape tip = s_.has_effect("tip_convolution") ? TipShape{s_.probe.tip_radius_nm, s_.probe.tip_half_angle_deg} : TipShape{};
    const double window = sphere_footprint_nm(r, tip) * 0.5 + kSearchMargin_nm;
    std::vector<cv::Point2d> others;
    for (const auto &q : model_->particles)
        if (q.id != id) others.emplace_back(q.x_nm, q.y_nm);
    // The bump nearest where it should be that is not another particle; not
    // in the scan (it went further than the model knows), a wider scan.
    for (double size : {ps.scan_size_nm, kWideScan * ps.scan_size_nm}) {
        const int px = static_cast<int>(std::lround(ps.scan_px * size / ps.scan_size_nm));
        const Field f{around.x - size / 2, around.y - size / 2, size, px};
        const cv::Mat h = instrument_->scan(f);
        ++rep_.local_scans;
        wait_s(ps.scan_s * size / ps.scan_size_nm);
        double x = 0, y = 0;
        if (nearest_bump(h, f, around.x, around.y, r, window, others, r, &x, &y)) {
            if (std::getenv("AFM_PLAN_TRACE"))
                std::fprintf(stderr, "plan: scan t %.3f particle %d around (%.1f, %.1f) found (%.1f, %.1f)\n", instrument_->time_s(), id, around.x,
                             around.y, x, y);
            *found = {x, y};
            return true;
        }
        if (std::getenv("AFM_PLAN_TRACE")) {
            double lo = 0, hi = 0;
            cv::minMaxLoc(h, &lo, &hi);
            std::fprintf(stderr, "plan: scan t %.3f particle %d around (%.1f, %.1f) size %.0f NOT FOUND (heights %.1f..%.1f nm)\n", instrument_->time_s(), id,
                         around.x, around.y, size, lo, hi);
        }
    }
    return false;
}

bool Planner::send_fix(int id, Vec2 at, bool place)
{
    std::string note;
    model_ = &instrument_->fix(id, at, place, &note);
    if (!note.empty()) {
        ++rep_.fixes_refused;
        return false;
    }
    ++rep_.fixes;
    // A drift fix the Kalman filter took in part (its gain short of 1)
    // leaves this particle's model short of where the scan shows it: the
    // scan places it (the drift is the filter's; the particle is seen).
    const particle_t *p = particle(id);
    if (!place && p && norm(Vec2{p->x_nm, p->y_nm} - at) > kPlaceAfterDrift_nm) return send_fix(id, at, true);
    return true;
}

bool Planner::scan_particle(int id, Vec2 around, bool place, Vec2 *found)
{
    if (!scan_at(id, around, found)) return false;
    const particle_t *p = particle(id);
    const Vec2 off = *found - Vec2{p->x_nm, p->y_nm};
    if (place) return send_fix(id, *found, true);
    // Drift, or was it disturbed? Within the scan's own scatter: neither
    // under the step filter (which would take the scatter whole); the
    // Kalman filter takes it as a measurement with the scan's variance (a
    // small share), so its drift is fed by every pre-push scan, not only by
    // those the scatter or the filter's lag push past the deadband.
    // Otherwise the nearest other particle is scanned too: found off by the
    // same it is drift (every model moves); if not, the particles were
    // disturbed, and each model alone is put right.
    if (norm(off) < kDriftDeadband_nm) return s_.fw_cal.drift_filter == "kalman" ? send_fix(id, *found, false) : true;
    const particle_t *ref = nullptr;
    double best = 1e300;
    for (const auto &q : model_->particles)
        if (q.id != id && std::hypot(q.x_nm - p->x_nm, q.y_nm - p->y_nm) < best) best = std::hypot(q.x_nm - p->x_nm, q.y_nm - p->y_nm), ref = &q;
    Vec2 ref_at;
    const int ref_id = ref ? ref->id : 0;
    const Vec2 ref_model = ref ? Vec2{ref->x_nm, ref->y_nm} : Vec2{};
    const Vec2 here = *found;
    if (ref) travel(ref_model, false, s_.op.plan.travel_speed_nm_per_s);
    const bool ref_found = ref && scan_at(ref_id, ref_model, &ref_at);
    if (ref_found && norm((ref_at - ref_model) - off) < kDriftDeadband_nm) return send_fix(id, here, false);
    ++rep_.disturbed;
    if (ref_found && norm(ref_at - ref_model) >= kDriftDeadband_nm) send_fix(ref_id, ref_at, true);
    return send_fix(id, here, true);
}

PlanItem Planner::push_particle(PlanInstrument &instrument, int id, Vec2 target_nm, Vec2 tip_nm)
{
    const auto wall0 = std::chrono::steady_clock::now();
    instrument_ = &instrument;
    tip_ = tip_nm;
    engaged_ = false;
    load_nN_ = 0;
    model_ = &instrument.block({tip_, false});
    PlanItem item;
    item.kind = "particle";
    item.id = id;
    item.target_nm = target_nm - drift();
    if (particle(id)) place_particle(item, item.target_nm);
    else item.why = "not in the firmware's model";
    rep_.items.push_back(item);
    rep_.finished_s = instrument.time_s();
    rep_.wall_s += std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count();
    return item;
}

void Planner::run(PlanInstrument &instrument)
{
    const auto wall0 = std::chrono::steady_clock::now();
    instrument_ = &instrument;
    tip_ = s_.start_nm();
    engaged_ = false;
    model_ = &instrument.block({tip_, false});
    for (const CutSpec &c : s_.op.plan.cuts) cut(c);
    if (!sites_.empty()) run_particles();
    if (!s_.wire_targets.empty()) run_wires();
    rep_.finished_s = instrument.time_s();
    rep_.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count();
}

}  // namespace afm
