// The planner's particles (planner.hpp, stages 1-3): each pushed onto its
// site in strokes, closed loop on the card's model, blockers cleared first.

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

struct Planner::Job {
    int site = 0;       // index in sites_
    int particle = 0;   // particle id
};

bool Planner::push_leg(int id, Vec2 end_A, bool slow_end)
{
    const PlanSpec &ps = s_.op.plan;
    const particle_t *p = particle(id);
    if (!p) return false;
    const double R = p->radius_nm + s_.probe.tip_radius_nm;
    Vec2 P{p->x_nm, p->y_nm};
    Vec2 u = unit(end_A - P);
    travel(P - (R + ps.approach_nm) * u, false, ps.travel_speed_nm_per_s);
    travel(tip_, true, ps.speed_nm_per_s);   // land
    const double T = 1.0 / s_.block_hz;
    const double far = norm(end_A - P) + ps.approach_nm;
    const long max_blocks = static_cast<long>(3 * far / ps.speed_nm_per_s * s_.block_hz) + static_cast<long>(s_.block_hz);
    bool touched = false, ok = false;
    Vec2 last_P = P;
    int still = 0;
    std::deque<bool> moved;   // since contact: whether the model moved, a block each, the last apart_max
    const int apart_max = std::max(3, static_cast<int>(std::lround(kApart_s * s_.block_hz)));
    for (long k = 0; k < max_blocks; ++k) {
        p = particle(id);
        if (!p) break;
        P = {p->x_nm, p->y_nm};
        still = norm(P - last_P) < 0.05 ? still + 1 : 0;
        last_P = P;
        const Vec2 rem = end_A - P;
        const double d = norm(rem);
        if (d <= (slow_end ? kStopSite_nm : kStop_nm)) {
            ok = true;
            break;
        }
        if (d > 20) u = unit(rem, u);
        const Vec2 c = P - tip_;
        touched = touched || p->in_contact;
        // Slipped off: the model moved in fewer than half of the last
        // apart_max blocks (pushed, it moves every block; what the card
        // still feels now and then, with the tip pressed into the model,
        // is not the particle).
        if (touched) {
            moved.push_back(still == 0);
            if (static_cast<int>(moved.size()) > apart_max) moved.pop_front();
            if (static_cast<int>(moved.size()) == apart_max && 2 * std::count(moved.begin(), moved.end(), true) < apart_max) break;
        }
        if (touched) {
            const double cosang = dot(unit(c, u), u);
            if (cosang < std::cos(kLostAngle_deg * kPi / 180) || norm(c) > R + ps.approach_nm + 30) break;   // lost
        }
        const Vec2 aim = P - (R - ps.push_depth_nm) * u;
        if (still > kStallBlocks && norm(aim - tip_) < 0.5) break;   // at its aim, nothing moves: it has slipped away
        const double v = slow_end ? std::clamp(d / kSlowOver_nm * ps.speed_nm_per_s, kSlowest_nm_per_s, ps.speed_nm_per_s) : ps.speed_nm_per_s;
        const Vec2 to = aim - tip_;
        tip_ = norm(to) <= v * T ? aim : tip_ + (v * T) * unit(to);
        model_ = &instrument_->block({tip_, true});
    }
    // Back off from the particle's model (the way it came, if the tip is on its centre).
    if (const particle_t *q = particle(id)) u = unit(Vec2{q->x_nm, q->y_nm} - tip_, u);
    travel(tip_ - kBackOff_nm * u, true, ps.speed_nm_per_s);
    travel(tip_, false, ps.travel_speed_nm_per_s);   // lift
    return ok;
}

bool Planner::locate(PlanItem &item, bool place, Vec2 *at)
{
    const particle_t *p = particle(item.id);
    if (!p) return false;
    const Vec2 P{p->x_nm, p->y_nm};
    travel(P, false, s_.op.plan.travel_speed_nm_per_s);
    ++item.scans;
    return scan_particle(item.id, P, place, at);
}

void Planner::check_disturbed(const std::vector<particle_t> &before, Vec2 drift_before, int pushed_id)
{
    // Another particle's model moved during a push (the firmware saw the
    // tip or the pushed particle touch it): a scan shows where it is. The
    // card's drift estimate moves every model (the Kalman filter's, block
    // by block): that move is not a touch.
    const Vec2 dd = drift() - drift_before;
    for (const particle_t &b : before) {
        if (b.id == pushed_id) continue;
        const particle_t *p = particle(b.id);
        if (!p || norm(Vec2{p->x_nm - b.x_nm, p->y_nm - b.y_nm} - dd) < kModelMoved_nm) continue;
        ++rep_.disturbed;
        PlanItem probe;
        probe.id = b.id;
        Vec2 at;
        locate(probe, true, &at);
    }
}

void Planner::place_particle(PlanItem &item, Vec2 site)
{
    const PlanSpec &ps = s_.op.plan;
    Vec2 at;
    // Where is it? Untouched since the model last saw it: the difference is drift.
    if (!locate(item, false, &at)) {
        item.why = "not found in the local scan around its model";
        return;
    }
    int attempts = 0;   // strokes that ended at the site
    for (int strokes = 0; strokes < kMaxStrokes; ++strokes) {
        const particle_t *p = particle(item.id);
        if (!p) {
            item.why = "not in the firmware's model";
            return;
        }
        const Vec2 from = Vec2{p->x_nm, p->y_nm} - drift();
        const PushPath path = plan_push(from, site, geometry(p->radius_nm), obstacles(item.id));
        if (!path.ok()) {
            item.why = "no free path to its site";
            return;
        }
        // One stroke: along the first leg, no longer than the model is
        // trusted to follow the particle.
        Vec2 end = path.legs[1];
        bool at_site = path.legs.size() == 2;
        const double len = stroke_length(from, end, stroke_nm_, kStrokeNear_nm, geometry(p->radius_nm), obstacles(item.id));
        if (len < norm(end - from)) {
            end = from + len * unit(end - from);
            at_site = false;
        }
        ++item.pushes;
        ++rep_.pushes;
        if (at_site && ++attempts > 1) ++rep_.repushes;
        const std::vector<particle_t> before = model_->particles;
        const Vec2 drift_before = drift();
        push_leg(item.id, end + drift(), at_site);
        check_disturbed(before, drift_before, item.id);
        // The check: a scan where the model has it; the model goes where it shows.
        const particle_t *q = particle(item.id);
        if (!q) {
            item.why = "not in the firmware's model";
            return;
        }
        const Vec2 model{q->x_nm, q->y_nm};
        if (!locate(item, true, &at)) {
            // not found, or found further from its model than the card accepts
            item.why = "lost: not found near its model after a push (or further off than the firmware accepts)";
            return;
        }
        // How far the model strayed over this stroke sets the next one's length.
        const double strayed = norm(at - model);
        if (std::getenv("AFM_PLAN_TRACE"))
            std::fprintf(stderr, "plan: t %.2f particle %d stroke %.0f nm (limit %.0f) at_site %d model (%.1f, %.1f) at (%.1f, %.1f) strayed %.1f nm\n", instrument_->time_s(), item.id, norm(end - from), stroke_nm_, at_site, model.x, model.y, at.x, at.y, strayed);
        if (strayed < kStrayLow_nm) stroke_nm_ = std::min(kStrokeMax_nm, stroke_nm_ * 1.5);
        else if (strayed > kStrayHigh_nm) stroke_nm_ = std::max(kStrokeMin_nm, stroke_nm_ * 0.5);
        if (!at_site) continue;
        // Aim for half the tolerance; take the tolerance on the last attempt.
        item.error_nm = norm(at - (site + drift()));
        if (item.error_nm <= ps.tolerance_nm * (attempts >= ps.max_pushes ? 1.0 : 0.5)) {
            item.placed = true;
            item.why.clear();
            return;
        }
        if (attempts >= ps.max_pushes) break;
    }
    std::ostringstream m;
    m.precision(3);
    if (attempts == 0) m << "not at its site after " << kMaxStrokes << " strokes";
    else m << "off its site by " << item.error_nm << " nm after " << attempts << " pushes onto it";
    item.why = m.str();
}

void Planner::clear_blockers(const std::vector<int> &assigned)
{
    // A spare particle on a site another particle is coming to: push it
    // outwards, away from the pattern's centre, until it is clear.
    const PlanSpec &ps = s_.op.plan;
    Vec2 centre{0, 0};
    for (const Vec2 &s : sites_) centre = centre + s;
    centre = (1.0 / sites_.size()) * centre;
    const double half = s_.field_nm / 2;
    for (const auto &p : std::vector<particle_t>(model_->particles)) {
        if (std::find(assigned.begin(), assigned.end(), p.id) != assigned.end()) continue;
        const Vec2 P = Vec2{p.x_nm, p.y_nm} - drift();
        double nearest = 1e300;
        Vec2 near_site;
        for (const Vec2 &s : sites_)
            if (norm(s - P) < nearest) nearest = norm(s - P), near_site = s;
        const double need = 2 * p.radius_nm + ps.clearance_nm;
        if (nearest >= need) continue;
        Vec2 out = unit(P - centre, unit(P - near_site));
        // To the nearest place outside every site's reach along that line.
        Vec2 to = P;
        for (int k = 1; k < 200; ++k) {
            to = P + (k * 0.5 * need) * out;
            bool clear = true;
            for (const Vec2 &s : sites_) clear = clear && norm(s - to) >= need + p.radius_nm;
            if (clear) break;
        }
        to.x = std::clamp(to.x, s_.field_center_nm.x - half + need, s_.field_center_nm.x + half - need);
        to.y = std::clamp(to.y, s_.field_center_nm.y - half + need, s_.field_center_nm.y + half - need);
        // Pushed there as any particle to its site (free paths, strokes, scans).
        PlanItem item;
        item.kind = "spare";
        item.id = p.id;
        item.target_nm = to;
        ++rep_.cleared;
        place_particle(item, to);
        if (item.placed) item.why = "a spare particle on a site: pushed aside";
        rep_.items.push_back(item);
    }
}

std::vector<PlanJob> Planner::jobs(const objects_t &model) const
{
    std::vector<Vec2> pos;
    std::vector<int> ids;
    double r = 0;
    for (const auto &p : model.particles) {
        pos.push_back(Vec2{p.x_nm - model.drift_nm[0], p.y_nm - model.drift_nm[1]});
        ids.push_back(p.id);
        r = std::max(r, p.radius_nm);
    }
    // A pinned site (objects.targets[j].particle) by the particle's index here.
    std::vector<int> pinned;
    for (int id : s_.targets.pinned) {
        const auto at = std::find(ids.begin(), ids.end(), id);
        if (id >= 0 && at == ids.end()) throw PlanError("objects.targets: particle " + std::to_string(id) + " is pinned to a site but not in the firmware's model");
        pinned.push_back(id < 0 ? -1 : static_cast<int>(at - ids.begin()));
    }
    const std::vector<int> who = assign_sites(pos, sites_, pinned);
    std::vector<PlanJob> out;
    for (int j : assembly_order(sites_, geometry(r))) out.push_back({j, ids[static_cast<std::size_t>(who[static_cast<std::size_t>(j)])]});
    return out;
}

void Planner::run_particles()
{
    const std::vector<PlanJob> order = jobs(*model_);
    std::vector<int> assigned(sites_.size(), -1);
    for (const PlanJob &j : order) assigned[static_cast<std::size_t>(j.site)] = j.particle;
    clear_blockers(assigned);

    std::vector<Job> left;
    for (const PlanJob &j : order) left.push_back({j.site, j.particle});
    while (!left.empty()) {
        // The innermost job with a free push.
        std::size_t pick = left.size();
        for (std::size_t k = 0; k < left.size() && pick == left.size(); ++k) {
            const particle_t *p = particle(left[k].particle);
            if (!p) continue;
            if (plan_push(Vec2{p->x_nm, p->y_nm} - drift(), sites_[left[k].site], geometry(p->radius_nm), obstacles(p->id)).ok())
                pick = k;
        }
        if (pick == left.size()) {
            for (const Job &j : left) {
                PlanItem item;
                item.kind = "particle";
                item.id = j.particle;
                item.target_nm = sites_[j.site];
                item.why = "no free path to its site";
                rep_.items.push_back(item);
            }
            break;
        }
        const Job j = left[pick];
        left.erase(left.begin() + static_cast<long>(pick));
        PlanItem item;
        item.kind = "particle";
        item.id = j.particle;
        item.target_nm = sites_[j.site];
        place_particle(item, sites_[static_cast<std::size_t>(j.site)]);
        rep_.items.push_back(item);
    }
    // A placed particle knocked off its site by a later push (its model was
    // put right by a scan when it moved) is pushed back.
    replace_knocked_off();
    register_at_end();
}

void Planner::register_at_end()
{
    // The pattern is judged at the end where the sites are by the card's
    // drift then: under the Kalman filter, the last drift it predicted
    // since its last fix. Placed particles scanned once more (each a drift
    // fix: the filter averages them) register it anew, spread over the
    // pattern (every k-th placed particle).
    if (s_.fw_cal.drift_filter != "kalman") return;
    std::vector<std::size_t> placed;
    for (std::size_t k = 0; k < rep_.items.size(); ++k)
        if (rep_.items[k].kind == "particle" && rep_.items[k].placed) placed.push_back(k);
    const std::size_t step = std::max<std::size_t>(1, placed.size() / kEndScans);
    for (std::size_t k = 0; k < placed.size(); k += step) {
        PlanItem probe = rep_.items[placed[k]];
        Vec2 at;
        locate(probe, false, &at);
        rep_.items[placed[k]].scans = probe.scans;
    }
}

void Planner::replace_knocked_off()
{
    const PlanSpec &ps = s_.op.plan;
    for (int pass = 0; pass < 2; ++pass)
        for (PlanItem &item : rep_.items) {
            if (item.kind != "particle" || !item.placed) continue;
            const particle_t *p = particle(item.id);
            if (!p || norm(Vec2{p->x_nm, p->y_nm} - (item.target_nm + drift())) <= ps.tolerance_nm) continue;
            item.placed = false;
            ++rep_.replaced;
            place_particle(item, item.target_nm);
        }
}


}  // namespace afm
