// operator: the scripted stand-in for the haptic joystick. Walks the scene's
// waypoint path at a constant apex speed; for every haptic force it receives
// (block n) it answers with the stylus pose for block n + 1, where the hand
// is at the end of block n (lockstep; the card asks for the first pose with
// a force of block -1).
#include <lcm/lcm-cpp.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <string>

#include "afm/haptic_force_t.hpp"
#include "afm/haptic_pose_t.hpp"
#include "afm/heartbeat_t.hpp"
#include "bus.hpp"
#include "scene.hpp"

namespace {

const char *kUsage =
    "usage: operator --scene FILE [--out DIR]\n"
    "  The scripted operator; normally started by ./afm run inside the run's namespace.\n";

// Apex target at time t (s) along the path, walking at constant speed.
afm::Vec2 path_point(const afm::Scene &s, double t)
{
    double left = s.op.speed_nm_per_s * t;
    const auto &p = s.op.path_nm;
    for (std::size_t i = 1; i < p.size(); ++i) {
        const double dx = p[i].x - p[i - 1].x, dy = p[i].y - p[i - 1].y;
        const double len = std::hypot(dx, dy);
        if (left <= len && len > 0) return afm::Vec2{p[i - 1].x + dx * left / len, p[i - 1].y + dy * left / len};
        left -= len;
    }
    return p.back();
}

struct Operator {
    const afm::Scene &scene;
    lcm::LCM &lc;
    afm::Heartbeat hb;
    int64_t answered = -2;   // last haptic force answered (-1: the card's request for pose 0)
    afm::haptic_pose_t last{};
    bool sim_done = false;
    double peak_force_N = 0;
    int64_t forces = 0;

    Operator(const afm::Scene &s, lcm::LCM &l) : scene(s), lc(l), hb(l, "operator") {}

    void on_force(const lcm::ReceiveBuffer *, const std::string &, const afm::haptic_force_t *f)
    {
        if (f->seq == answered) {      // resent force: our pose was lost
            lc.publish(AFM_CH_HAPTIC_POSE, &last);
            return;
        }
        if (f->seq != answered + 1) return;
        peak_force_N = std::max(peak_force_N, std::hypot(f->force_N[0], f->force_N[1]));
        ++forces;
        const int64_t t_us = afm::block_end_utime(scene, f->seq);
        const afm::Vec2 p = path_point(scene, t_us * 1e-6);
        const double reach = scene.op.kappa * scene.field_nm / 2;
        last.utime = t_us;
        last.seq = f->seq + 1;
        last.joy[0] = (p.x - scene.field_center_nm.x) / reach;
        last.joy[1] = (p.y - scene.field_center_nm.y) / reach;
        last.joy[2] = 0;
        last.load_nN = scene.op.load_nN;
        last.engaged = true;
        answered = f->seq;
        lc.publish(AFM_CH_HAPTIC_POSE, &last);
        hb.maybe_send("running", f->seq, t_us);
    }

    void on_heartbeat(const lcm::ReceiveBuffer *, const std::string &, const afm::heartbeat_t *m)
    {
        if ((m->name == "sim_afm" && m->state == "done") || (m->name == "launcher" && m->state == "stop")) sim_done = true;
    }
};

}  // namespace

int main(int argc, char **argv)
{
    std::string scene_path, out_dir;
    for (int i = 1; i < argc; ++i) {
        std::string a = argv[i];
        if (a == "--scene" && i + 1 < argc) scene_path = argv[++i];
        else if (a == "--out" && i + 1 < argc) out_dir = argv[++i];
        else if (a == "-h" || a == "--help") { std::fputs(kUsage, stdout); return 0; }
        else { std::fprintf(stderr, "operator: unknown argument '%s'\n%s", a.c_str(), kUsage); return 2; }
    }
    if (scene_path.empty()) { std::fputs(kUsage, stderr); return 2; }
    try {
        const afm::Scene scene = afm::load_scene(scene_path);
        auto lc = afm::open_bus();
        Operator op(scene, *lc);
        lc->subscribe(AFM_CH_HAPTIC_FORCE, &Operator::on_force, &op)->setQueueCapacity(afm::kQueueCapacity);
        lc->subscribe(AFM_CH_AFM_HEARTBEAT, &Operator::on_heartbeat, &op)->setQueueCapacity(afm::kQueueCapacity);
        while (!op.sim_done) {
            op.hb.maybe_send(op.answered < -1 ? "ready" : "running", op.answered, 0, op.answered < -1 ? 200000 : 1000000);
            lc->handleTimeout(100);
        }
        if (!out_dir.empty()) {
            std::ofstream rep(out_dir + "/operator_report.json");
            rep << "{\"poses\": " << op.forces << ", \"peak_haptic_force_N\": " << op.peak_force_N << "}\n";
        }
        op.hb.send("done", op.answered, 0);
        return 0;
    } catch (const afm::SceneError &e) {
        std::fprintf(stderr, "%s\n", e.what());
        return 2;
    } catch (const std::exception &e) {
        std::fprintf(stderr, "operator: %s\n", e.what());
        return 1;
    }
}
