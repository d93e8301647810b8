// What the scripted operator means to do with the stylus: walk the scene's
// waypoints (operator.path_nm) at operator.speed_nm_per_s, one block at a
// time. The hand (haptic_device.hpp) pulls the stylus towards this aim.
//
// mode script: the walk ignores the force (the operator does not react).
// mode feel: the operator stops a stroke when it feels contact, as a person
// does: when the force on the stylus against the stroke's direction exceeds
// feel_threshold_N, the stroke ends where the aim is and the next one
// starts from there. A stroke that has stopped re-arms once the force has
// fallen below half the threshold, so one contact ends one stroke.
#pragma once

#include <vector>

#include "scene.hpp"

namespace afm {

class HandScript {
public:
    explicit HandScript(const Scene &s);

    // The aim (apex target, frame A, nm) at the end of the next `dt_s`,
    // given the force the hand feels now (N, frame A axes).
    Vec2 advance(double dt_s, Vec2 felt_N);

    struct Contact { double t_s; Vec2 aim_nm; double force_N; int stroke; };
    const std::vector<Contact> &contacts() const { return contacts_; }   // feel: the strokes it ended
    bool finished() const { return seg_ + 1 >= path_.size(); }

private:
    std::vector<Vec2> path_;
    double speed_;
    bool feel_;
    double threshold_N_;
    std::size_t seg_ = 0;      // moving from path_[seg_] (or where the last stroke stopped) to path_[seg_ + 1]
    Vec2 aim_;
    double t_s_ = 0;
    bool armed_ = true;
    std::vector<Contact> contacts_;
};

}  // namespace afm
