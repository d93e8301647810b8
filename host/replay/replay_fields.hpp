// afm_replay's comparison of one output (replay/main.cpp runs it over a
// whole log): the card's outputs flattened to named fields in their units
// by the walk generated from their .lcm files, keyed by (block, channel,
// fix), and compared recorded against replayed, naming the first field that
// differs.
#pragma once

#include <cstdint>
#include <stdexcept>
#include <string>
#include <string_view>
#include <tuple>
#include <type_traits>
#include <vector>

#include "afm/fw_state_t.hpp"
#include "afm/haptic_force_t.hpp"
#include "afm/tip_cmd_t.hpp"

namespace afm::replay {

// The outputs in the order a block publishes them.
extern const std::vector<std::string> kOutputs;
// The three channels FW_STATE replaced (2026-11, issue 15): a recording
// made before holds them instead. Their types are gone from the bus; replay
// compares such a recording's other outputs and says that FW_STATE was not.
extern const std::vector<std::string> kBeforeFwState;

int output_rank(const std::string &ch);

// One field of a message, flattened: its name, its value, and whether it is
// a force (compared in pN) or a position (in nm).
enum class Unit { kOther, kForce_pN, kPosition_nm };
struct Field {
    std::string name;
    double value;
    Unit unit;
};

// A message's fields in the order of its .lcm file: the visitor of the
// generated walk (afm_lcm_walk.hpp, from tools/gen_lcm_walk.py), which names
// every field and the unit its comment states. A field in nN is kept in pN,
// one in nm as a position.
class Flat {
public:
    std::vector<Field> f;
    template <class T>
    void operator()(const std::string &name, const T &v, const char *unit)
    {
        static_assert(std::is_arithmetic_v<T>, "replay compares numbers: an output with a string field needs its comparison here");
        const std::string_view u(unit);
        const double x = static_cast<double>(v);
        if (u == "nN")
            f.push_back({name, x * 1e3, Unit::kForce_pN});
        else
            f.push_back({name, x, u == "nm" ? Unit::kPosition_nm : Unit::kOther});
    }
};

struct DecodeError : std::runtime_error {
    using std::runtime_error::runtime_error;
};

template <class M>
M decode_recorded(const std::vector<uint8_t> &d, const char *type)
{
    M m;
    if (m.decode(d.data(), 0, static_cast<int>(d.size())) < 0) throw DecodeError(std::string("does not decode as ") + type);
    return m;
}

// Key of an output: (block, rank of its channel, fix id).
using Key = std::tuple<int64_t, int, int32_t>;
Key output_key(const std::string &ch, const std::vector<uint8_t> &d);

// A recorded output's fields (AFM_CMD, HAPTIC_FORCE, FW_STATE), by the walk.
Flat flatten(const std::string &ch, const std::vector<uint8_t> &d);

struct ChannelStats {
    int64_t compared = 0;
    int64_t differing = 0;
    int64_t missing_new = 0;       // recorded, not produced by the replay
    int64_t missing_recorded = 0;  // produced by the replay, not in the recording
    double worst_pN = 0;
    double worst_nm = 0;
};

struct Divergence {
    bool found = false;
    Key key;
    std::string text;
};

std::string fmt(double v);

// Compares one recorded output with the replay's; fills the per-channel
// figures, and the divergence's text if it is the first.
bool compare(const std::string &ch, const std::vector<uint8_t> &rec, const std::vector<uint8_t> &now, ChannelStats *st,
             std::string *first);

}  // namespace afm::replay
