#include "summary.hpp"

#include <cstdio>
#include <string>

#include "verdict.hpp"

namespace afm::launch {

namespace {

// The card on its board (--firmware qemu): its instructions per block against a 168 MHz budget.
void print_board(const nlohmann::json &run)
{
    if (!run.contains("card") || !run["card"].is_object() || !run["card"].contains("board")) return;
    const auto &b = run["card"]["board"];
    if (b.value("firmware", "host") != "qemu" || !b.contains("budget")) return;
    const auto &i = b["instructions_per_block"], &g = b["budget"];
    std::printf("run: the card on its board (%s): %.0f instructions a block median, %.0f worst (%.0f, %.0f a sample); "
                "%.2f %% of a 168 MHz Cortex-M4's block at CPI 1 worst, %.2f %% at CPI 2 (icount counts instructions, not "
                "cycles); a round trip %.0f us median\n",
                b["machine"].get<std::string>().c_str(), i["median"].get<double>(), i["worst"].get<double>(),
                b["instructions_per_sample"]["median"].get<double>(), b["instructions_per_sample"]["worst"].get<double>(),
                100 * g["fraction_worst_cpi1"].get<double>(), 100 * g["fraction_worst_cpi2"].get<double>(),
                b["round_trip_us"]["median"].get<double>());
}

// What the page's bridge refused (run.json launcher.view_bridge), when it refused anything.
void print_view_bridge(const nlohmann::json &b)
{
    if (!b.is_object() || !b.contains("rejected")) return;
    const int64_t unproven = b["rejected"]["unproven"].value("total", int64_t{0});
    const int64_t foreign = b["rejected"].value("foreign_datagrams", int64_t{0});
    if (unproven + foreign == 0) return;
    std::printf("run: the page's bridge refused %lld messages without the run's proof and %lld from no process of the run that "
                "publishes their channel (logs/view_bridge.log)\n",
                static_cast<long long>(unproven), static_cast<long long>(foreign));
}

// What the hand felt: in mode feel, the strokes a contact ended
// (contacts_felt); in mode script, which does not react to force and so
// ends no stroke, the largest force the hand felt (peak_haptic_force_N).
std::string hand_felt(const nlohmann::json &op)
{
    char text[160];
    if (op.value("mode", std::string()) == "feel")
        std::snprintf(text, sizeof text, "%zu contacts felt (strokes ended by the force)",
                      op.contains("contacts_felt") ? op["contacts_felt"].size() : std::size_t{0});
    else
        std::snprintf(text, sizeof text, "the hand felt up to %.3g N (mode %s: strokes do not stop at contact)",
                      op.value("peak_haptic_force_N", 0.0), op.value("mode", std::string("script")).c_str());
    return text;
}

// The planner's account (operator_report.json) and its result in the
// fresh scan (fidelity.json "assembly"), as run.json holds them.
void print_plan(const nlohmann::json &run)
{
    if (run.contains("operator") && run["operator"].contains("haptic")) {
        const auto &h = run["operator"]["haptic"];
        std::printf("run: haptic: gain %.3f N/nN, K_r %.0f N/m against the bound %.0f N/m (%s); the passivity controller acted in %ld "
                    "blocks, %.3g J; %s\n",
                    h.value("gain_N_per_nN", 0.0), h.value("rendered_stiffness_N_per_m", 0.0), h.value("passivity_bound_N_per_m", 0.0),
                    h.value("passive", false) ? "inside" : "OUTSIDE", h.value("controller_blocks", 0L), h.value("controller_energy_J", 0.0),
                    hand_felt(run["operator"]).c_str());
    }
    if (!run.contains("operator") || !run["operator"].contains("plan")) return;
    const auto &p = run["operator"]["plan"];
    const double done_s = p["finished_sim_s"].is_number() ? p["finished_sim_s"].get<double>() : -1;
    char when[128];
    if (done_s >= 0) std::snprintf(when, sizeof when, "done at %.1f simulated s (%.1f wall s)", done_s, p.value("planner_wall_s", 0.0));
    else std::snprintf(when, sizeof when, "NOT done when the run ended (give a longer duration_s)");
    std::printf("run: plan: %d pushes (%d again after a miss), %d local scans, %d fixes; %s\n", p.value("pushes", 0),
                p.value("repushes", 0), p.value("local_scans", 0), p.value("fixes", 0), when);
    if (!run.contains("fidelity") || !run["fidelity"].contains("assembly")) return;
    const auto &pl = run["fidelity"]["assembly"];
    if (pl.contains("particles")) {
        const auto &q = pl["particles"];
        std::printf("run: assembly (a fresh scan): %d of %d sites hold a particle within %.0f nm (%d empty); worst %.1f nm, RMS %.1f nm\n",
                    q.value("placed", 0), q.value("sites", 0), q.value("tolerance_nm", 0.0), q.value("missing", 0),
                    q.value("worst_nm", 0.0), q.value("rms_nm", 0.0));
    }
    if (pl.contains("rods"))
        for (const auto &r : pl["rods"]) {
            char err[64] = "not found in the scan";
            if (r["error_nm"].is_number()) std::snprintf(err, sizeof err, "ends within %.1f nm", r["error_nm"].get<double>());
            std::printf("run: assembly (a fresh scan): rod %d %s (tolerance %.0f nm), %s\n", r.value("id", 0),
                        r.value("placed", false) ? "on its target" : "OFF its target", r.value("tolerance_nm", 0.0), err);
        }
}

}  // namespace

void print_summary(const nlohmann::json &run, double wall_s, int64_t messages, const std::string &hosts_line, const std::string &out)
{
    const double sim_s = run["sim_seconds"].get<double>();
    std::printf("run: ok: %.2f simulated s in %.2f wall s (%.2f sim s per wall s), %d frames, %lld bus messages\n", sim_s, wall_s,
                wall_s > 0 ? sim_s / wall_s : 0.0, run["frames"].get<int>(), static_cast<long long>(messages));
    if (run["timing"]["loop_realtime_factor"].is_number())
        std::printf("run: the loop, first block to last: %.2f wall s, %.1f us a block, %.2f x real time (the rest of the run: %.2f s)\n",
                    run["timing"]["loop_seconds"].get<double>(), run["timing"]["loop_us_per_block"].get<double>(),
                    run["timing"]["loop_realtime_factor"].get<double>(), run["timing"]["outside_loop_seconds"].get<double>());
    if (run.contains("fidelity")) {
        const auto &fj = run["fidelity"];
        // null: an object the display shows was not found in the scan (an infinite error)
        auto num = [&](const char *k) { return fj.contains(k) && fj[k].is_number() ? fj[k].get<double>() : -1.0; };
        const double max_err = num("max_position_error_nm");
        char err[64];
        if (max_err >= 0) std::snprintf(err, sizeof err, "%.2f nm", max_err);
        else std::snprintf(err, sizeof err, "(an object not found in the scan)");
        std::printf("run: fidelity (display vs a fresh scan at frame %d): max object position error %s, RMS height "
                    "difference %.2f nm (%s)\n",
                    fj.value("frame", 0), err, num("rms_height_error_nm"), fj.value("pass", false) ? "within target" : "OUTSIDE the 5 nm target");
    }
    print_plan(run);
    print_board(run);
    print_view_bridge(run["launcher"]["view_bridge"]);
    if (!hosts_line.empty())
        std::printf("%s; the simulator resent %lld blocks\n", hosts_line.c_str(),
                    static_cast<long long>(run.contains("sim") ? run["sim"].value("resends", 0L) : 0L));
    std::printf("run: output in %s\n", out.c_str());
    std::printf("%s\n", afm::verdict_line(run["verdict"]).c_str());
}

}  // namespace afm::launch
