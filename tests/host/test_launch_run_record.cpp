// The run record (launch/run_record.hpp): a record assembled from given
// parts and reports carries the schema version and exactly the keys
// docs/design.md's table lists (those written only on failure aside), the
// parts where they belong, the log's completeness; run.json is written
// whole (no .partial left), and a folder it cannot be written in leaves
// none and says which file.
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <regex>
#include <set>
#include <sstream>
#include <string>

#include "run_record.hpp"
#include "scene.hpp"

extern "C" {
#include "unity.h"
}

namespace fs = std::filesystem;
using nlohmann::json;

static std::string dir;
static afm::Scene scene;

void setUp()
{
    dir = (fs::temp_directory_path() / ("test_run_record." + std::to_string(getpid()))).string();
    fs::remove_all(dir);
    fs::create_directories(dir + "/frames");
}
void tearDown() { fs::remove_all(dir); }

static void put(const std::string &name, const json &j) { std::ofstream(dir + "/" + name) << j.dump(); }

// docs/design.md's run.json keys, and those only written on failure (as tests/e2e/test_contract.py reads them).
static std::set<std::string> documented(std::set<std::string> *on_failure)
{
    std::ifstream f(std::string(AFM_SOURCE_DIR) + "/docs/design.md");
    std::stringstream ss;
    ss << f.rdbuf();
    std::string text = ss.str();
    text = text.substr(text.find("| key | meaning |"));
    text = text.substr(0, text.find("\n\n"));
    std::set<std::string> keys;
    std::istringstream lines(text);
    std::string line;
    for (int i = 0; std::getline(lines, line); ++i) {
        if (i < 2) continue;
        const std::string first = line.substr(1, line.find('|', 1) - 1);
        const std::regex name("`([a-z_]+)`");
        for (auto it = std::sregex_iterator(first.begin(), first.end(), name); it != std::sregex_iterator(); ++it) {
            keys.insert((*it)[1]);
            if (line.find("only when something failed") != std::string::npos) on_failure->insert((*it)[1]);
        }
    }
    return keys;
}

static afm::launch::RunParts parts()
{
    afm::launch::RunParts p;
    p.out = dir;
    p.scene_abs = "/s/short.yaml";
    p.scene_hash = "fnv1a64:0";
    p.scene = &scene;
    p.netns = "unknown";
    p.bus_url = "udpm://bus";
    p.sim_seconds = 0.5;
    p.wall_seconds = 2.0;
    afm::launch::Child c{"sim_afm"};
    c.exit_code = 0;
    p.processes.push_back(afm::launch::process_json(c));
    p.hosts = {{"count", 1}};
    p.launcher = {{"recorded_events", 3}};
    p.placement = {{"on", false}, {"why", "placement off"}};
    p.provenance = nullptr;
    p.loop_cpu = {{{"sim_afm", {1.0, -1}}}, {{"sim_afm", {1.5, -1}}}};
    return p;
}

static void reports()
{
    put("sim_report.json", {{"blocks", 100}, {"loop_wall_seconds", 0.5}, {"effects", json::array()}});
    put("fw_report.json", json::object());
    put("renderer_report.json", json::object());
    put("operator_report.json", json::object());
    put("fidelity.json", {{"pass", true}});
}

void test_a_record_has_the_schema_version_and_the_documented_keys()
{
    reports();
    const json run = afm::launch::assemble(parts());
    TEST_ASSERT_EQUAL(afm::launch::kRunSchemaVersion, run["schema_version"].get<int>());
    std::set<std::string> on_failure;
    const std::set<std::string> keys = documented(&on_failure);
    TEST_ASSERT_TRUE(keys.size() > 20);
    for (const auto &[k, v] : run.items()) TEST_ASSERT_TRUE_MESSAGE(keys.count(k), ("not in docs/design.md: " + k).c_str());
    for (const auto &k : keys)
        if (!on_failure.count(k)) TEST_ASSERT_TRUE_MESSAGE(run.contains(k), ("documented but not written: " + k).c_str());
}

void test_the_parts_and_reports_land_where_they_belong()
{
    reports();
    afm::launch::RunParts p = parts();
    p.failure = "fw_node died";
    const json run = afm::launch::assemble(p);
    TEST_ASSERT_EQUAL_STRING("failed", run["status"].get<std::string>().c_str());
    TEST_ASSERT_EQUAL_STRING("fw_node died", run["error"].get<std::string>().c_str());
    TEST_ASSERT_EQUAL_DOUBLE(0.25, run["sim_seconds_per_wall_second"].get<double>());
    TEST_ASSERT_EQUAL(3, run["launcher"]["recorded_events"].get<int>());
    TEST_ASSERT_EQUAL(100, run["sim"]["blocks"].get<int>());
    TEST_ASSERT_TRUE(run["timing"]["loop_cpu_us_per_block"].contains("sim_afm"));
    TEST_ASSERT_EQUAL_DOUBLE(5000.0, run["timing"]["loop_cpu_us_per_block"]["sim_afm"].get<double>());
    TEST_ASSERT_TRUE(run.contains("log_error"));   // no bus.lcmlog
    TEST_ASSERT_FALSE(run["log"]["complete"].get<bool>());
    TEST_ASSERT_EQUAL(0, run["log"]["analog_blocks_recorded"].get<int>());
    p.interrupted = 15;
    TEST_ASSERT_EQUAL_STRING("interrupted", afm::launch::assemble(p)["status"].get<std::string>().c_str());
}

void test_a_report_that_is_not_json_is_named()
{
    std::ofstream(dir + "/fw_report.json") << "{ half";
    const json run = afm::launch::assemble(parts());
    TEST_ASSERT_EQUAL_STRING("fw_report.json: not valid JSON", run["report_errors"][0].get<std::string>().c_str());
}

void test_run_json_is_written_whole_or_not_at_all()
{
    const json run = {{"schema_version", 2}, {"status", "ok"}};
    TEST_ASSERT_EQUAL_STRING("", afm::launch::write_record(dir, run).c_str());
    std::ifstream f(dir + "/run.json");
    TEST_ASSERT_TRUE(json::parse(f) == run);
    TEST_ASSERT_FALSE(fs::exists(dir + "/run.json.partial"));
    const std::string gone = dir + "/gone";
    const std::string why = afm::launch::write_record(gone, {{"status", "failed"}, {"error", "x"}});
    TEST_ASSERT_TRUE_MESSAGE(why.rfind("cannot write " + gone + "/run.json: ", 0) == 0, why.c_str());
    TEST_ASSERT_TRUE_MESSAGE(why.find("status would have been 'failed': x") != std::string::npos, why.c_str());
    TEST_ASSERT_FALSE(fs::exists(gone + "/run.json"));
}

int main()
{
    scene = afm::load_scene(std::string(AFM_SOURCE_DIR) + "/scenes/short.yaml");
    UNITY_BEGIN();
    RUN_TEST(test_a_record_has_the_schema_version_and_the_documented_keys);
    RUN_TEST(test_the_parts_and_reports_land_where_they_belong);
    RUN_TEST(test_a_report_that_is_not_json_is_named);
    RUN_TEST(test_run_json_is_written_whole_or_not_at_all);
    return UNITY_END();
}
