// fw_node: the A/D card's firmware on the bus. Receives the analog blocks,
// runs the firmware/ modules sample by sample (acquisition, force,
// compensation, particle model), publishes forces, the apex and the objects,
// closes the haptic loop with the operator, and acknowledges each block with
// the next tip command (lockstep).
#include <lcm/lcm-cpp.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "afm/analog_block_t.hpp"
#include "afm/fw_force_t.hpp"
#include "afm/fw_tip_t.hpp"
#include "afm/haptic_force_t.hpp"
#include "afm/haptic_pose_t.hpp"
#include "afm/heartbeat_t.hpp"
#include "afm/object_fix_t.hpp"
#include "afm/objects_t.hpp"
#include "afm/tip_cmd_t.hpp"
#include "bus.hpp"
#include "fw_config.hpp"
#include "scene.hpp"

static_assert(FW_FLAG_SAT_SN == afm::fw_force_t::FLAG_SAT_SN, "flag bits must match the firmware");
static_assert(FW_FLAG_SAT_SL == afm::fw_force_t::FLAG_SAT_SL, "flag bits must match the firmware");
static_assert(FW_FLAG_FX_UNOBSERVABLE == afm::fw_force_t::FLAG_FX_UNOBSERVABLE, "flag bits must match the firmware");
static_assert(FW_FLAG_VIRTUAL_SN == afm::fw_force_t::FLAG_VIRTUAL_SN, "flag bits must match the firmware");
static_assert(FW_FLAG_SAT_FORCE == afm::fw_force_t::FLAG_SAT_FORCE, "flag bits must match the firmware");
static_assert(FW_FLAG_CONTACT == afm::fw_force_t::FLAG_CONTACT, "flag bits must match the firmware");
static_assert(FW_FLAG_THETA_UNKNOWN == afm::fw_force_t::FLAG_THETA_UNKNOWN, "flag bits must match the firmware");
static_assert(FW_FLAG_SAT_POS == afm::fw_force_t::FLAG_SAT_POS, "flag bits must match the firmware");
static_assert(FW_FLAG_SQUEEZE == afm::fw_force_t::FLAG_SQUEEZE, "flag bits must match the firmware");

namespace {

const char *kUsage =
    "usage: fw_node --scene FILE [--crash-at-block N]\n"
    "  The firmware on the bus; normally started by ./afm run inside the run's namespace.\n"
    "  --crash-at-block N  failure injection: exit with code 70 on receiving block N\n";

constexpr int kCrashExitCode = 70;

constexpr int kMaxParticles = 4096;
constexpr int kMaxWires = 64;
constexpr int kMaxTrenchPoints = 8192;
constexpr double kTrenchStep_nm = 5.0;        // a trench point per 5 nm of tip path
constexpr double kMaxDriftStep_nm = 200.0;     // a local scan further off than this is not drift (fw_drift.h)
constexpr double kHapticGain_N_per_nN = 0.1;   // stylus force per tip force
constexpr double kHapticMax_N = 3.0;           // the device's force limit

struct Node {
    const afm::Scene &scene;
    lcm::LCM &lc;
    afm::Heartbeat hb;
    fw_board_t board{};
    std::vector<fw_sample_in_t> block_in;     // one analog block, as the card's DMA buffer holds it
    std::vector<fw_sample_out_t> block_out;
    fw_particles_t parts{};
    fw_drift_t drift{};
    std::vector<fw_wire_t> wires;             // rigid-rod models (fw_wire), ids alongside
    std::vector<int32_t> wire_ids;
    int32_t wire_friction_fl_pn_per_um = 0;   // f, pN per um of wire length
    fw_litho_t litho{};
    std::vector<fw_trench_point_t> trench_pts;
    bool have_litho = false;
    int32_t fix_id = 0;           // last object fix applied
    std::vector<fw_particle_t> storage;
    int64_t done = -1;            // last block processed
    int64_t crash_at = -1;        // failure injection
    int64_t commanded = -1;       // last block acknowledged with a command
    bool sim_done = false;
    int64_t sat_count = 0;
    afm::fw_force_t last_force{};
    afm::fw_tip_t last_tip{};
    afm::objects_t last_objects{};
    afm::haptic_force_t last_haptic{};
    afm::tip_cmd_t last_cmd{};

    Node(const afm::Scene &s, lcm::LCM &l) : scene(s), lc(l), hb(l, "fw_node"), storage(kMaxParticles)
    {
        const fw_board_config_t cfg = afm::board_config(s);
        if (fw_board_init(&board, &cfg) != FW_OK) throw std::runtime_error("fw_board_init: " + afm::board_config_refusal(s));
        if (fw_particles_init(&parts, storage.data(), kMaxParticles, afm::to_i32(s.probe.tip_radius_nm * 1e3)) != FW_OK)
            throw std::runtime_error("fw_particles_init failed");
        fw_particles_set_friction(&parts, cfg.mu_ppm, cfg.adhesion_pn, 0);
        fw_drift_init(&drift, afm::to_i32(kMaxDriftStep_nm * 1e3));
        if (s.wires.size() > static_cast<std::size_t>(kMaxWires))
            throw std::runtime_error("the firmware's wire model holds at most " + std::to_string(kMaxWires) + " wires");
        for (const auto &w : s.wires) {
            fw_wire_t m{};
            const double dx = w.x1_nm - w.x0_nm, dy = w.y1_nm - w.y0_nm;
            const int32_t psi_mdeg = afm::to_i32(std::atan2(dy, dx) * 180e3 / M_PI);
            if (fw_wire_init(&m, afm::to_i32((w.x0_nm + w.x1_nm) * 500.0), afm::to_i32((w.y0_nm + w.y1_nm) * 500.0),
                             fw_math_bam_from_mdeg(psi_mdeg), afm::to_i32(std::hypot(dx, dy) * 1e3), afm::to_i32(w.diameter_nm * 1e3)) != FW_OK)
                throw std::runtime_error("fw_wire_init refused wire " + std::to_string(w.id));
            wires.push_back(m);
            wire_ids.push_back(w.id);
        }
        wire_friction_fl_pn_per_um = afm::to_i32(s.wire_model.friction_nN_per_um * 1e3);
        if (s.has_effect("lithography")) {
            trench_pts.resize(kMaxTrenchPoints);
            const fw_status_t st = fw_litho_init(&litho, trench_pts.data(), kMaxTrenchPoints, afm::to_i32(s.litho.threshold_nN * 1e3),
                                                 afm::to_i32(s.litho.depth_nm_per_nN * 65536.0),   // nm/nN = pm/pN, 16.16
                                                 afm::to_i32(s.probe.tip_half_angle_deg * 1e3), afm::to_i32(kTrenchStep_nm * 1e3));
            if (st != FW_OK) throw std::runtime_error("fw_litho_init refused the scene's lithography settings");
            have_litho = true;
        }
        const int32_t th = afm::to_i32(afm::particle_threshold_nN(s) * 1e3);
        for (const auto &p : s.particles) {
            if (fw_particles_add(&parts, p.id, afm::to_i32(p.x_nm * 1e3), afm::to_i32(p.y_nm * 1e3),
                                 afm::to_i32(p.radius_nm * 1e3), th) != FW_OK)
                throw std::runtime_error("the firmware's particle model is full (" + std::to_string(kMaxParticles) + ")");
        }
    }

    // Rigid-rod models (fw_wire): a rod the apex overlaps, while the lateral
    // force exceeds the tip's friction baseline by half the rod's minimum
    // push k(l) f L (section 6), is pushed along its normal until the apex
    // sits on its surface, in steps of at most L/4 (fw_wire_push's limit).
    static constexpr uint32_t kWirePushed = 1u << 16;   // fw_wire_t.flags bit the node sets: pushed this sample

    uint32_t update_wires(const fw_sample_out_t &out)
    {
        uint32_t flags = 0;
        if (wires.empty()) return 0;
        const double lateral = std::hypot(static_cast<double>(out.force_pn[0]), static_cast<double>(out.force_pn[1]));
        const double baseline = board.cfg.mu_ppm * 1e-6 * (out.force_pn[2] + board.cfg.adhesion_pn);
        const int32_t reach0 = afm::to_i32(scene.probe.tip_radius_nm * 1e3);
        for (auto &w : wires) {
            w.flags &= ~kWirePushed;
            bool touch;
            int32_t l, dn;
            if (fw_wire_contact(&w, out.tip_pm, reach0 + w.diameter_pm / 2, &touch, &l, &dn) != FW_OK || !touch) continue;
            fw_wire_static_t st;
            if (fw_wire_static_point(w.length_pm, l, &st) != FW_OK) continue;
            bool sat = false;
            const int32_t fl = afm::to_i32(static_cast<double>(wire_friction_fl_pn_per_um) * w.length_pm * 1e-6);
            const int32_t threshold = fw_wire_push_threshold_pn(st.k, fl, &sat);
            if (lateral - baseline <= 0.5 * threshold) continue;
            const int32_t max_step = w.length_pm / 4;
            while (dn != 0) {
                const int32_t step = std::clamp(dn, -max_step, max_step);
                if (fw_wire_push(&w, l, step, nullptr) != FW_OK) break;
                dn -= step;
            }
            w.flags |= kWirePushed;
            flags |= FW_FLAG_CONTACT;
        }
        return flags;
    }

    void fill_objects(int64_t utime, int64_t seq)
    {
        last_objects = afm::objects_t{};
        last_objects.utime = utime;
        last_objects.seq = seq;
        for (int32_t i = 0; i < fw_particles_count(&parts); ++i) {
            const fw_particle_t *p = fw_particles_get(&parts, i);
            afm::particle_t q;
            q.id = p->id;
            q.x_nm = p->x_pm * 1e-3;
            q.y_nm = p->y_pm * 1e-3;
            q.radius_nm = p->radius_pm * 1e-3;
            q.in_contact = (p->flags & FW_PARTICLE_PUSHED) != 0;
            last_objects.particles.push_back(q);
        }
        last_objects.n_particles = static_cast<int32_t>(last_objects.particles.size());
        for (std::size_t i = 0; i < wires.size(); ++i) {
            const fw_wire_t &w = wires[i];
            q30_t sn, cs;
            fw_math_sincos_q30(w.psi, &sn, &cs);
            const double h = w.length_pm * 0.5e-3, c = cs / 1073741824.0, si = sn / 1073741824.0;
            afm::wire_t q;
            q.id = wire_ids[i];
            q.diameter_nm = w.diameter_pm * 1e-3;
            q.n = 2;
            q.x_nm = {w.x_pm * 1e-3 - h * c, w.x_pm * 1e-3 + h * c};
            q.y_nm = {w.y_pm * 1e-3 - h * si, w.y_pm * 1e-3 + h * si};
            q.in_contact = (w.flags & kWirePushed) != 0;
            last_objects.wires.push_back(q);
        }
        last_objects.n_wires = static_cast<int32_t>(last_objects.wires.size());
        if (have_litho) {
            afm::trench_t t{};
            auto flush = [&] {
                if (t.n > 0) {
                    t.id = static_cast<int32_t>(last_objects.trenches.size()) + 1;
                    last_objects.trenches.push_back(t);
                }
                t = afm::trench_t{};
            };
            for (int32_t i = 0; i < litho.count; ++i) {
                const fw_trench_point_t &p = trench_pts[i];
                if (p.flags & FW_LITHO_STROKE_START) flush();
                t.x_nm.push_back(p.x_pm * 1e-3);
                t.y_nm.push_back(p.y_pm * 1e-3);
                t.depth_nm.push_back(p.depth_pm * 1e-3);
                t.width_nm.push_back(p.width_pm * 1e-3);
                ++t.n;
            }
            flush();
        }
        last_objects.n_trenches = static_cast<int32_t>(last_objects.trenches.size());
        last_objects.drift_nm[0] = drift.offset_pm[0] * 1e-3;
        last_objects.drift_nm[1] = drift.offset_pm[1] * 1e-3;
        last_objects.fix_id = fix_id;
    }

    // A local scan located an object: the difference to the model is drift
    // (fw_drift), applied to every object. Answered by republishing the
    // objects with fix_id, so the display knows the model is re-registered.
    void on_fix(const lcm::ReceiveBuffer *, const std::string &, const afm::object_fix_t *m)
    {
        if (m->fix_id == fix_id + 1) {
            // The object's modelled position: a particle's model, or a
            // landmark's scene position carried along by the drift so far.
            // A landmark may have jumped far (a cantilever change): its fix
            // accepts up to half the field instead of the drift step.
            bool found = false, landmark = false;
            int32_t model[2] = {0, 0};
            for (int32_t i = 0; i < fw_particles_count(&parts); ++i) {
                const fw_particle_t *p = fw_particles_get(&parts, i);
                if (p->id == m->object_id) {
                    model[0] = p->x_pm;
                    model[1] = p->y_pm;
                    found = true;
                }
            }
            for (const auto &lm : scene.landmarks) {
                if (found || lm.id != m->object_id) continue;
                model[0] = afm::to_i32(lm.x_nm * 1e3 + drift.offset_pm[0]);
                model[1] = afm::to_i32(lm.y_nm * 1e3 + drift.offset_pm[1]);
                found = landmark = true;
            }
            if (!found) {
                std::fprintf(stderr, "fw_node: local scan fix %d names unknown object %d; ignored\n", m->fix_id, m->object_id);
            } else {
                const int32_t drift_step = drift.max_step_pm;
                if (landmark) drift.max_step_pm = afm::to_i32(scene.field_nm * 500.0);

                const int32_t scan[2] = {afm::to_i32(m->scan_x_nm * 1e3), afm::to_i32(m->scan_y_nm * 1e3)};
                int32_t delta[2];
                const fw_status_t st = fw_drift_measure(&drift, model, scan, delta);
                drift.max_step_pm = drift_step;
                if (st == FW_OK)
                    fw_drift_apply(delta, &parts, wires.data(), static_cast<int32_t>(wires.size()), have_litho ? &litho : nullptr);
                else
                    std::fprintf(stderr, "fw_node: local scan fix %d: object %d is %.1f nm from its model, more than drift; not applied\n",
                                 m->fix_id, m->object_id, std::hypot(scan[0] - model[0], scan[1] - model[1]) * 1e-3);
            }
            fix_id = m->fix_id;
            fill_objects(last_objects.utime, last_objects.seq);
        }
        if (m->fix_id <= fix_id) lc.publish(AFM_CH_FW_OBJECTS, &last_objects);
    }

    void publish_outputs()
    {
        lc.publish(AFM_CH_FW_FORCE, &last_force);
        lc.publish(AFM_CH_FW_TIP, &last_tip);
        lc.publish(AFM_CH_FW_OBJECTS, &last_objects);
        lc.publish(AFM_CH_HAPTIC_FORCE, &last_haptic);
    }

    void on_analog(const lcm::ReceiveBuffer *, const std::string &, const afm::analog_block_t *b)
    {
        if (b->seq == done) {   // a resend: our answer was lost somewhere
            publish_outputs();
            if (commanded == done) lc.publish(AFM_CH_AFM_CMD, &last_cmd);
            return;
        }
        if (b->seq == crash_at) {
            std::fprintf(stderr, "fw_node: failure injection: crashing at block %lld\n", (long long)b->seq);
            std::exit(kCrashExitCode);
        }
        if (b->seq != done + 1) {
            std::fprintf(stderr, "fw_node: ignoring block %lld (expected %lld)\n", (long long)b->seq, (long long)(done + 1));
            return;
        }
        uint32_t flags = 0;
        fw_sample_out_t out{};
        int64_t force_sum_pn[3] = {0, 0, 0};
        // the card's DMA block: acquisition, compensation and force for the
        // whole block in one call, then the object models sample by sample
        block_in.resize(static_cast<size_t>(b->n));
        block_out.resize(static_cast<size_t>(b->n));
        for (int i = 0; i < b->n; ++i) {
            fw_sample_in_t &in = block_in[static_cast<size_t>(i)];
            in.sn_uv = afm::to_i32(b->sn_v[i] * 1e6);
            in.sl_uv = afm::to_i32(b->sl_v[i] * 1e6);
            in.piezo_pm[0] = afm::to_i32(b->piezo_x_nm[i] * 1e3);
            in.piezo_pm[1] = afm::to_i32(b->piezo_y_nm[i] * 1e3);
            in.piezo_pm[2] = afm::to_i32(b->piezo_z_nm[i] * 1e3);
        }
        fw_board_step_block(&board, block_in.data(), block_out.data(), block_in.size());
        for (int i = 0; i < b->n; ++i) {
            out = block_out[static_cast<size_t>(i)];
            fw_particles_update(&parts, out.tip_pm, out.force_pn, out.flags);
            out.flags |= update_wires(out);
            if (have_litho && fw_litho_step(&litho, out.tip_pm, out.force_pn[2]) == FW_ERR_CAPACITY) out.flags |= FW_FLAG_SAT_POS;
            const uint32_t f = out.flags | fw_particles_flags(&parts);
            if (f & (FW_FLAG_SAT_SN | FW_FLAG_SAT_SL)) ++sat_count;
            flags |= f;
            for (int k = 0; k < 3; ++k) force_sum_pn[k] += out.force_pn[k];
        }
        const int64_t t_end = afm::block_end_utime(scene, b->seq);
        last_force.utime = t_end;
        last_force.seq = b->seq;
        for (int k = 0; k < 3; ++k) last_force.force_nN[k] = b->n > 0 ? force_sum_pn[k] * 1e-3 / b->n : 0.0;
        last_force.flags = static_cast<int32_t>(flags);
        last_force.sn_code = out.sn_code;
        last_force.sl_code = out.sl_code;
        last_force.sat_count = sat_count;

        last_tip.utime = t_end;
        last_tip.seq = b->seq;
        for (int k = 0; k < 3; ++k) last_tip.tip_nm[k] = out.tip_pm[k] * 1e-3;
        last_tip.piezo_nm[0] = b->piezo_x_nm[b->n - 1];
        last_tip.piezo_nm[1] = b->piezo_y_nm[b->n - 1];
        last_tip.piezo_nm[2] = b->piezo_z_nm[b->n - 1];

        fill_objects(t_end, b->seq);

        last_haptic.utime = t_end;
        last_haptic.seq = b->seq;
        for (int k = 0; k < 3; ++k) {
            last_haptic.tip_force_nN[k] = last_force.force_nN[k];
            last_haptic.force_N[k] = std::clamp(last_force.force_nN[k] * kHapticGain_N_per_nN, -kHapticMax_N, kHapticMax_N);
        }
        last_haptic.flags = last_force.flags;
        done = b->seq;
        publish_outputs();
        hb.maybe_send("running", done, t_end);
    }

    void on_pose(const lcm::ReceiveBuffer *, const std::string &, const afm::haptic_pose_t *p)
    {
        if (p->seq != done + 1) return;        // a late duplicate, or not ours yet
        if (commanded == done) {                // duplicate pose: resend our answer
            lc.publish(AFM_CH_AFM_CMD, &last_cmd);
            return;
        }
        int32_t joy[2], cmd_pm[2];
        for (int k = 0; k < 2; ++k) joy[k] = static_cast<int32_t>(std::clamp<long long>(std::llround(p->joy[k] * 32768.0), -32768, 32767));
        fw_board_piezo_cmd(&board, joy, cmd_pm);
        // The joystick's workspace follows the sample as the display does: the
        // drift the local scans measured shifts the command with the models.
        for (int k = 0; k < 2; ++k)
            cmd_pm[k] = afm::to_i32(static_cast<double>(cmd_pm[k]) + drift.offset_pm[k]);
        last_cmd.utime = p->utime;
        last_cmd.ack_seq = done;
        last_cmd.piezo_x_nm = cmd_pm[0] * 1e-3;
        last_cmd.piezo_y_nm = cmd_pm[1] * 1e-3;
        last_cmd.load_nN = p->load_nN;
        last_cmd.engaged = p->engaged;
        commanded = done;
        lc.publish(AFM_CH_AFM_CMD, &last_cmd);
    }

    void on_heartbeat(const lcm::ReceiveBuffer *, const std::string &, const afm::heartbeat_t *m)
    {
        if ((m->name == "sim_afm" && m->state == "done") || (m->name == "launcher" && m->state == "stop")) sim_done = true;
    }
};

}  // namespace

int main(int argc, char **argv)
{
    std::string scene_path;
    int64_t crash_at = -1;
    for (int i = 1; i < argc; ++i) {
        std::string a = argv[i];
        if (a == "--scene" && i + 1 < argc) scene_path = argv[++i];
        else if (a == "--crash-at-block" && i + 1 < argc) crash_at = std::atoll(argv[++i]);
        else if (a == "-h" || a == "--help") { std::fputs(kUsage, stdout); return 0; }
        else { std::fprintf(stderr, "fw_node: unknown argument '%s'\n%s", a.c_str(), kUsage); return 2; }
    }
    if (scene_path.empty()) { std::fputs(kUsage, stderr); return 2; }
    try {
        const afm::Scene scene = afm::load_scene(scene_path);
        auto lc = afm::open_bus();
        Node node(scene, *lc);
        node.crash_at = crash_at;
        lc->subscribe(AFM_CH_AFM_ANALOG, &Node::on_analog, &node)->setQueueCapacity(afm::kQueueCapacity);
        lc->subscribe(AFM_CH_HOST_OBJECT_FIX, &Node::on_fix, &node)->setQueueCapacity(afm::kQueueCapacity);
        lc->subscribe(AFM_CH_HAPTIC_POSE, &Node::on_pose, &node)->setQueueCapacity(afm::kQueueCapacity);
        lc->subscribe(AFM_CH_AFM_HEARTBEAT, &Node::on_heartbeat, &node)->setQueueCapacity(afm::kQueueCapacity);
        while (!node.sim_done) {
            node.hb.maybe_send(node.done < 0 ? "ready" : "running", node.done,
                               node.done < 0 ? 0 : afm::block_end_utime(scene, node.done), node.done < 0 ? 200000 : 1000000);
            lc->handleTimeout(100);
        }
        node.hb.send("done", node.done, node.done < 0 ? 0 : afm::block_end_utime(scene, node.done));
        return 0;
    } catch (const afm::SceneError &e) {
        std::fprintf(stderr, "%s\n", e.what());
        return 2;
    } catch (const std::exception &e) {
        std::fprintf(stderr, "fw_node: %s\n", e.what());
        return 1;
    }
}
