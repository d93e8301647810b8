// Unity tests of a measured substrate (sample.substrate: {gsf: FILE}): the
// simulator images the map's heights, interpolated bilinearly between its
// pixel centres, and the tip's z follows them; the scene reader refuses a bad
// file naming the file, the key and the value. The GSF files are written
// here byte by byte from the format's description (not by the bench's writer).
#include <unity.h>

#include <sys/stat.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <functional>
#include <limits>
#include <string>
#include <vector>

#include "../scene_text.hpp"
#include "world.hpp"

using afm::sim::World;

namespace {

const char *kScene = R"(name: measured-unit
seed: 2
duration_s: 1
sample_rate_hz: 20000
block_hz: 1000
frame_rate_hz: 25
effects: [EFFECTS]
sample:
  substrate: {gsf: FILE MATERIAL}
  field_nm: 2000
operator:
  load_nN: 5
  path_nm: [[0, 0]]
)";

struct Map {
    int nx = 41, ny = 41;
    double x0_nm = -1100, y0_nm = -1100, w_nm = 2200, h_nm = 2200;   // lower-left corner and size
    std::string header_extra, z_units = "m";
    int drop_bytes = 0;                                         // truncate the data by this many bytes
    std::function<double(double, double)> f;                    // height (nm) at a pixel centre (x, y nm)
};

double cx(const Map &m, int c) { return m.x0_nm + (c + 0.5) * m.w_nm / m.nx; }
double cy(const Map &m, int r) { return m.y0_nm + m.h_nm - (r + 0.5) * m.h_nm / m.ny; }   // row 0 at the top

std::string write_map(const std::string &name, const Map &m)
{
    const std::string path = "/tmp/" + name;
    char hdr[512];
    std::snprintf(hdr, sizeof hdr,
                  "Gwyddion Simple Field 1.0\nXRes = %d\nYRes = %d\nXReal = %.12g\nYReal = %.12g\nXOffset = %.12g\nYOffset = %.12g\n"
                  "XYUnits = m\nZUnits = %s\n%s",
                  m.nx, m.ny, m.w_nm * 1e-9, m.h_nm * 1e-9, m.x0_nm * 1e-9, m.y0_nm * 1e-9, m.z_units.c_str(), m.header_extra.c_str());
    std::string bytes(hdr);
    bytes.append(4 - bytes.size() % 4, '\0');
    for (int r = 0; r < m.ny; ++r)
        for (int c = 0; c < m.nx; ++c) {
            const float v = static_cast<float>(m.f(cx(m, c), cy(m, r)) * 1e-9);
            unsigned char b[4];
            std::memcpy(b, &v, 4);   // little-endian host
            bytes.append(reinterpret_cast<const char *>(b), 4);
        }
    bytes.resize(bytes.size() - static_cast<std::size_t>(m.drop_bytes));
    std::ofstream(path, std::ios::binary) << bytes;
    return path;
}

std::string scene(const std::string &file, const std::string &effects = "adhesion", const std::string &material = "")
{
    return with(with(with(kScene, "FILE", file), "EFFECTS", effects), " MATERIAL", material.empty() ? "" : ", material: " + material);
}

// Exactly bilinear: a + b x + c y + d x y is its own bilinear interpolant.
double bilinear_field(double x, double y) { return 3.0 + 0.004 * x - 0.002 * y + 2e-6 * x * y; }

}  // namespace

void setUp() {}
void tearDown() {}

void test_image_heights_follow_the_map_bilinearly()
{
    // A bilinear map is reproduced everywhere inside it (float32 rounding of
    // heights up to ~12 nm: 1e-5 nm); a sine's pixel centres are hit exactly
    // (1e-5 nm) and a point between two centres is their mean; beyond the
    // map the nearest edge continues.
    Map m;
    m.f = bilinear_field;
    const World w(scene_from_text(scene(write_map("afm-measured-bilinear.gsf", m))));
    for (double x = -1050; x <= 1050; x += 73.3)
        for (double y = -1040; y <= 1040; y += 91.7) TEST_ASSERT_DOUBLE_WITHIN(1e-5, bilinear_field(x, y), w.image_height(x, y));
    Map s;
    s.f = [](double x, double y) { return 5.0 * std::sin(2 * M_PI * x / 700.0) + 0.001 * y; };
    const World v(scene_from_text(scene(write_map("afm-measured-sine.gsf", s))));
    for (int r = 0; r < s.ny; r += 7)
        for (int c = 0; c < s.nx; c += 3) {
            TEST_ASSERT_DOUBLE_WITHIN(1e-5, s.f(cx(s, c), cy(s, r)), v.image_height(cx(s, c), cy(s, r)));
            if (c + 1 < s.nx) {
                const double mid = 0.5 * (s.f(cx(s, c), cy(s, r)) + s.f(cx(s, c + 1), cy(s, r)));
                TEST_ASSERT_DOUBLE_WITHIN(1e-5, mid, v.image_height(0.5 * (cx(s, c) + cx(s, c + 1)), cy(s, r)));
            }
        }
    // beyond the last column (x > 1073.2 nm): the edge column's heights
    const double edge = s.f(cx(s, s.nx - 1), cy(s, 20));
    TEST_ASSERT_DOUBLE_WITHIN(1e-5, edge, v.image_height(3000, cy(s, 20)));
    TEST_ASSERT_TRUE(std::fabs(edge) > 1.0);   // not the flat plane's 0
    // with tip convolution (no objects): the same substrate
    const World t(scene_from_text(scene(write_map("afm-measured-sine.gsf", s), "adhesion, tip_convolution")));
    TEST_ASSERT_DOUBLE_WITHIN(1e-12, v.image_height(123.4, -56.7), t.image_height(123.4, -56.7));
    TEST_ASSERT_TRUE(has(v.models_built(), "substrate_map"));
}

void test_the_tip_meets_the_map()
{
    // Engaged at a point, the piezo's z is the map under the apex less the
    // set point's deflection (1e-9 nm), at two points of a step's two levels.
    Map m;
    m.f = [](double x, double) { return x < 0 ? 0.0 : 20.0; };
    const afm::Scene s = scene_from_text(scene(write_map("afm-measured-step.gsf", m)));
    for (double x : {-400.0, 400.0}) {
        World w(s);
        w.command(Eigen::Vector2d(x, 100), 5, true);
        afm::sim::Sample smp{};
        for (int i = 0; i < 2000; ++i) smp = w.step();
        const double defl = 5 / w.lever().spring;
        TEST_ASSERT_DOUBLE_WITHIN(1e-9, w.image_height(w.apex().x(), w.apex().y()) - defl, smp.piezo_nm.z());
        TEST_ASSERT_DOUBLE_WITHIN(1e-6, x < 0 ? 0.0 : 20.0, w.image_height(w.apex().x(), w.apex().y()));
    }
}

void test_material_and_a_named_substrate()
{
    // The material sets the elastic and friction defaults (glass unless
    // given); a named substrate builds no map.
    Map m;
    m.f = bilinear_field;
    const std::string f = write_map("afm-measured-bilinear.gsf", m);
    TEST_ASSERT_EQUAL_STRING("glass", scene_from_text(scene(f)).substrate.c_str());
    TEST_ASSERT_EQUAL_STRING("polycarbonate", scene_from_text(scene(f, "adhesion", "polycarbonate")).substrate.c_str());
    TEST_ASSERT_TRUE(scene_error(scene(f, "adhesion", "tilted_glass")).find("sample.substrate.material") != std::string::npos);
    const afm::Scene named = scene_from_text(with(with(kScene, "{gsf: FILE MATERIAL}", "glass"), "EFFECTS", "adhesion"));
    TEST_ASSERT_FALSE(named.substrate_map);
    TEST_ASSERT_FALSE(has(World(named).models_built(), "substrate_map"));
    // a relative name is the scene's directory's (scene_from_text writes in /tmp)
    TEST_ASSERT_TRUE(scene_from_text(scene("afm-measured-bilinear.gsf")).substrate_map != nullptr);
}

void test_bad_files_are_refused_naming_file_key_and_value()
{
    Map ok;
    ok.f = bilinear_field;
    struct Row {
        int line;
        std::string file;            // a path written (or not) before the scene is read
        std::vector<std::string> says;
    };
    mkdir("/tmp/afm-measured-dir.gsf", 0700);
    Map trunc = ok, nan = ok, huge = ok, small = ok, units = ok, tall = ok, res1 = ok;
    trunc.drop_bytes = 4;
    nan.f = [](double x, double y) { return x > 0 && y > 0 ? std::numeric_limits<double>::quiet_NaN() : 0.0; };
    huge.nx = 5000;
    huge.f = [](double, double) { return 0.0; };
    small.w_nm = 1500;   // covers x [-1100, 400]: not the field's +1000
    units.z_units = "V";
    tall.f = [](double x, double) { return x > 0 ? 3000.0 : 0.0; };
    res1.ny = 1;
    const Row rows[] = {
        {__LINE__, "/tmp/afm-measured-missing.gsf", {"afm-measured-missing.gsf", "No such file"}},
        {__LINE__, "/tmp/afm-measured-dir.gsf", {"afm-measured-dir.gsf", "not a regular file"}},
        {__LINE__, write_map("afm-measured-trunc.gsf", trunc), {"afm-measured-trunc.gsf", "6720 data bytes", "6724 expected"}},
        {__LINE__, write_map("afm-measured-nan.gsf", nan), {"afm-measured-nan.gsf", "not finite", "nan"}},
        {__LINE__, write_map("afm-measured-huge.gsf", huge), {"afm-measured-huge.gsf", "XRes", "'5000'", "[2, 4096]"}},
        {__LINE__, write_map("afm-measured-small.gsf", small), {"afm-measured-small.gsf", "x [-1100, 400]", "must cover the field"}},
        {__LINE__, write_map("afm-measured-units.gsf", units), {"afm-measured-units.gsf", "ZUnits", "'V'"}},
        {__LINE__, write_map("afm-measured-tall.gsf", tall), {"afm-measured-tall.gsf", "3e-06 m", "z range"}},
        {__LINE__, write_map("afm-measured-res1.gsf", res1), {"afm-measured-res1.gsf", "YRes", "'1'"}},
    };
    for (const Row &r : rows) {
        const std::string msg = scene_error(scene(r.file));
        char where[512];
        std::snprintf(where, sizeof where, "row at line %d: %s", r.line, msg.c_str());
        TEST_ASSERT_TRUE_MESSAGE(msg.find("sample.substrate.gsf") != std::string::npos, where);
        for (const auto &s : r.says) TEST_ASSERT_TRUE_MESSAGE(msg.find(s) != std::string::npos, where);
    }
    rmdir("/tmp/afm-measured-dir.gsf");
    std::ofstream("/tmp/afm-measured-text.gsf") << "not a map\n";
    const std::string msg = scene_error(scene("/tmp/afm-measured-text.gsf"));
    TEST_ASSERT_TRUE_MESSAGE(msg.find("not a Gwyddion Simple Field file") != std::string::npos, msg.c_str());
}

static void remove_the_maps()
{
    for (const char *n : {"bilinear", "sine", "step", "trunc", "nan", "huge", "small", "units", "tall", "res1", "text"})
        unlink(("/tmp/afm-measured-" + std::string(n) + ".gsf").c_str());
}

int main()
{
    UNITY_BEGIN();
    RUN_TEST(test_image_heights_follow_the_map_bilinearly);
    RUN_TEST(test_the_tip_meets_the_map);
    RUN_TEST(test_material_and_a_named_substrate);
    RUN_TEST(test_bad_files_are_refused_naming_file_key_and_value);
    const int failures = UNITY_END();
    remove_the_maps();
    return failures;
}
