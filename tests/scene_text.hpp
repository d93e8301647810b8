// Test helper (simulator and host tests): a Scene from YAML text, through the
// real parser and validator.
#pragma once

#include <unity.h>

#include <fstream>
#include <string>
#include <vector>
#include <unistd.h>

#include "scene.hpp"

inline afm::Scene scene_from_text(const std::string &text)
{
    char path[] = "/tmp/afm-test-scene-XXXXXX";
    const int fd = mkstemp(path);
    TEST_ASSERT_TRUE(fd >= 0);
    close(fd);
    std::ofstream(path) << text;
    try {
        afm::Scene s = afm::load_scene(path);
        unlink(path);
        return s;
    } catch (...) {
        unlink(path);   // a refused scene leaves no file behind either
        throw;
    }
}

// What the scene reader says when it refuses `text` (SceneError's message),
// or "" when it accepts it.
inline std::string scene_error(const std::string &text)
{
    try {
        scene_from_text(text);
    } catch (const afm::SceneError &e) {
        return e.what();
    }
    return "";
}

// Replaces the first occurrence of `key` in `text` by `value`.
inline std::string with(std::string text, const std::string &key, const std::string &value)
{
    const auto at = text.find(key);
    if (at != std::string::npos) text.replace(at, key.size(), value);
    return text;
}

// Whether `x` is among `v` (e.g. a model in World::models_built()).
inline bool has(const std::vector<std::string> &v, const std::string &x)
{
    for (const auto &e : v)
        if (e == x) return true;
    return false;
}
