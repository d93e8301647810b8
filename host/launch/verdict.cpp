#include "verdict.hpp"

#include <algorithm>
#include <cstdio>
#include <map>

namespace afm {

namespace {

using nlohmann::json;

double num(const json &j, const char *key, double dflt = 0)
{
    return j.is_object() && j.contains(key) && j[key].is_number() ? j[key].get<double>() : dflt;
}

std::string f1(double v)
{
    char b[32];
    std::snprintf(b, sizeof b, "%.1f", v);
    return b;
}

// The failures of each check, by name (detail text), "" when it passed or
// did not apply.
std::map<std::string, std::string> failures(const json &run)
{
    std::map<std::string, std::string> out;
    const json fid = run.value("fidelity", json::object());
    if (fid.is_object() && fid.contains("pass") && !fid["pass"].get<bool>()) {
        const double err = num(fid, "max_position_error_nm", -1);
        out["fidelity"] = (err >= 0 ? "the display is " + f1(err) + " nm off a fresh scan (worst object)"
                                    : std::string("an object the display shows is not in the fresh scan")) +
                          ", RMS height " + f1(num(fid, "rms_height_error_nm")) + " nm, against its " + f1(num(fid, "target_nm")) + " nm target";
    }
    const json pl = fid.is_object() ? fid.value("assembly", json::object()) : json::object();
    std::string place;
    if (pl.contains("particles")) {
        const json &q = pl["particles"];
        if (num(q, "placed") < num(q, "sites") || num(q, "missing") > 0)
            place = std::to_string(q.value("placed", 0)) + " of " + std::to_string(q.value("sites", 0)) +
                    " sites hold a particle within " + f1(num(q, "tolerance_nm")) + " nm";
    }
    if (pl.contains("rods"))
        for (const auto &r : pl["rods"])
            if (!r.value("placed", false))
                place += (place.empty() ? "" : "; ") + std::string("rod ") + std::to_string(r.value("id", 0)) + " off its target";
    if (!place.empty()) out["assembly"] = place;
    const json fw = run.value("fw", json::object());
    if (num(fw, "interlock_trips") > 0)
        out["interlock"] = "the card's force interlock tripped " + std::to_string(fw["interlock_trips"].get<long long>()) + " times";
    if (num(fw, "saturated_samples") > 0)
        out["saturation"] = std::to_string(fw["saturated_samples"].get<long long>()) + " samples with an ADC saturated";
    if (num(fw, "unobservable_push_blocks") > 0)
        out["unobservable_push"] = std::to_string(fw["unobservable_push_blocks"].get<long long>()) +
                                   " blocks pushed an object along the lever's axis, where F_x is unobservable";
    const json sol = run.value("sim", json::object()).value("solver", json::object());
    if (num(sol, "unconverged_samples") > 0)
        out["solver"] = std::to_string(sol["unconverged_samples"].get<long long>()) + " samples of the simulator's contact solver unconverged at its cap of " +
                        std::to_string(sol.value("cap", 0)) + " sweeps (tolerances " + sol.value("force_tolerance_nN", json(0)).dump() + " nN, " +
                        sol.value("gap_tolerance_nm", json(0)).dump() + " nm)";
    return out;
}

}  // namespace

json judge(const json &run, const std::vector<std::string> &expect)
{
    const auto fails = failures(run);
    json failed = json::array(), met = json::array();
    for (const auto &[check, detail] : fails) {
        if (std::find(expect.begin(), expect.end(), check) != expect.end()) met.push_back(check);
        else failed.push_back({{"check", check}, {"detail", detail}});
    }
    for (const auto &e : expect)
        if (!fails.count(e))
            failed.push_back({{"check", "expect"}, {"detail", "the scene expects " + e + " to fail (expect:), and it passed"}});
    return {{"pass", failed.empty()}, {"failed", failed}, {"expected", expect}, {"met", met}};
}

std::string verdict_line(const json &v)
{
    std::string met;
    for (const auto &m : v["met"]) met += (met.empty() ? "" : ", ") + m.get<std::string>();
    const std::string as_expected = met.empty() ? "" : " (failed as the scene expects: " + met + ")";
    if (v["pass"].get<bool>()) return "run: verdict: pass" + as_expected;
    std::string s = "run: verdict: FAILED";
    const char *sep = ": ";
    for (const auto &f : v["failed"]) {
        s += sep + f["check"].get<std::string>() + " (" + f["detail"].get<std::string>() + ")";
        sep = "; ";
    }
    return s + as_expected;
}

}  // namespace afm
