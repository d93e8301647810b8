// The scene-to-card table: each of the card's scalar settings
// (fw_card_config_t, its board's fw_board_config_t among them) as one row,
// naming the scene key(s) it comes from, the conversion into the firmware's
// units and Q formats (fw_units.h), and the firmware rules (fw_rules.h) it
// feeds. card_setup.cpp fills the configuration from it; the card's refusal
// names a rule's scene keys from it (card_rule_keys). What the card is
// given changes here, and only here.
//
// The card is given what a lab would have, never the simulator's truth
// (the scene's probe and sample sections): a row's constant is the scene's
// card section (firmware.*) where it gives one, else what a bench
// calibration measured (firmware.calibration.*, analysis/card_calib.py),
// else the card's nominal, named "firmware.KEY (nominal)". The run's
// settings (the field, the scan angle, the operator's scale and device)
// are the card's configuration. An absent optional key is named with -1.
// The keys of a rule are those of every row that feeds it, in the table's
// order, each named once; the first names the refusal's line.
#pragma once

extern "C" {
#include "fw_card.h"
}

#include <string>
#include <utility>
#include <vector>

#include "scene.hpp"

namespace afm {

// Scene keys with the values the scene holds for them.
using SceneKeys = std::vector<std::pair<std::string, double>>;

struct CardRow {
    const char *field;                                        // as fw_card.h names it: "board.mu_ppm"
    SceneKeys (*keys)(const Scene &);                         // where it comes from
    void (*fill)(const Scene &, fw_card_config_t *);          // the conversion; rows above it are filled
    std::vector<fw_rule_t> rules;                             // the firmware rules it feeds
};

// The table, in the order a rule's keys are named and the rows filled.
const std::vector<CardRow> &card_rows();

// Fills every row of the table into *c (the lists, flags and storage are
// card_setup.cpp's).
void fill_card_rows(const Scene &s, fw_card_config_t *c);

// Where each of the card's constants came from, a row's key at a time:
// source "scene card section" (firmware.*), "calibration run <id>"
// (firmware.calibration.*; the scanner's model, firmware.scanner.*, from
// ./afm calib scanner), "nominal", or "scene configuration" (the run's
// settings). run.json's card_sources (host/launch/run_record.cpp).
struct CardSource {
    std::string field, key;   // "board.mu_ppm", "firmware.calibration.mu"
    double value;             // in the key's units
    std::string source;
};
std::vector<CardSource> card_sources(const Scene &s);

// The scene keys whose values feed `rule`, with those values (this names
// inputs; the rule itself is the firmware's). Empty for a rule no row feeds.
SceneKeys card_rule_keys(const Scene &s, fw_rule_t rule);

}  // namespace afm
