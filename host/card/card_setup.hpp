// The card's configuration as a lab would flash it, from the scene: the
// scene's doubles converted to the firmware's integers (fw_units.h) and
// nothing else; each scalar setting by its row of the scene-to-card table
// (card_table.hpp), the lists (particles, wires, landmarks), the flags and
// the storage here. The firmware owns every rule about them: card_refusal
// runs fw_card_init and, when it refuses, names the rule in the firmware's
// words (fw_rule_text) with the scene keys that feed it (the table's) and
// their values.
#pragma once

extern "C" {
#include "fw_card.h"
}

#include <string>
#include <vector>

#include "scene.hpp"

namespace afm {

// Trench points the card can hold (fw_litho's storage) when the scene cuts.
constexpr int kCardTrenchCapacity = 8192;

// The configuration and the storage it points into (non-copyable: the
// configuration holds pointers to its own vectors).
class CardSetup {
public:
    explicit CardSetup(const Scene &s);
    CardSetup(const CardSetup &) = delete;
    CardSetup &operator=(const CardSetup &) = delete;

    const fw_card_config_t &config() const { return cfg_; }
    const fw_card_storage_t &storage() const { return storage_; }

private:
    fw_card_config_t cfg_{};
    fw_card_storage_t storage_{};
    std::vector<fw_card_particle_t> particles_;
    std::vector<fw_card_wire_t> wires_;
    std::vector<fw_card_landmark_t> landmarks_;
    std::vector<fw_particle_t> particle_store_;
    std::vector<fw_wire_t> wire_store_;
    std::vector<fw_trench_point_t> trench_store_;
    std::vector<fw_sample_out_t> scratch_;
};

// Why the card (fw_card_init, the firmware itself) refuses the scene: one
// line "key: ..." naming the rule and the scene keys and values that feed
// it, as SceneError does; empty when the card accepts it. The launcher
// checks it before anything starts; fw_node says it if init fails anyway.
std::string card_refusal(const Scene &s);
// The same line for a rule fw_card_init already named.
std::string card_refusal_text(const Scene &s, const CardSetup &setup, fw_rule_t rule);

}  // namespace afm
