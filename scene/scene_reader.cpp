// The scene reader (scene_reader.hpp): which nodes came from an include,
// and a material pair's friction and adhesion.
#include "scene_reader.hpp"

namespace afm::scene_detail {


// The nodes the includes brought into the scene this thread reads
// (merge_missing adds them; resolved_yaml starts the list afresh): an error
// never quotes them, as an included file is never quoted.
thread_local std::vector<YAML::Node> t_included;

// Whether n is tree or inside it (by identity, keys too).
bool within(const YAML::Node &tree, const YAML::Node &n)
{
    if (tree.is(n)) return true;
    if (tree.IsMap()) {
        for (auto it = tree.begin(); it != tree.end(); ++it)
            if (within(it->first, n) || within(it->second, n)) return true;
    } else if (tree.IsSequence()) {
        for (const auto &e : tree)
            if (within(e, n)) return true;
    }
    return false;
}

bool from_include(const YAML::Node &n)
{
    return std::any_of(t_included.begin(), t_included.end(), [&](const YAML::Node &t) { return within(t, n); });
}

// A material pair's friction and adhesion. with_area: the pair's shear
// strength and contact area too (the particle on the substrate, whose
// sliding threshold the simulator takes as mu F_a + tau A); the tip on the
// substrate slides by Amontons' law alone (mu and adhesion_nN), so those
// two keys, which nothing would read, are refused there by name.
ContactSpec read_contact(const Reader &r, const YAML::Node &n, const std::string &path, ContactSpec d, bool with_area)
{
    if (!n.IsDefined() || n.IsNull()) return d;
    if (!with_area && n.IsMap())   // the tip's contact: these two name the particles' own, said as such
        for (const char *k : {"shear_strength_MPa", "contact_area_nm2"})
            if (n[k].IsDefined())
                r.fail(path + "." + k, "not used: the tip slides on the substrate by mu and adhesion_nN alone (a shear strength and "
                                       "contact area belong to sample.particle_substrate)");
    if (with_area)
        r.only_keys(n, path, {"mu", "adhesion_nN", "shear_strength_MPa", "contact_area_nm2"});
    else
        r.only_keys(n, path, {"mu", "adhesion_nN"});
    ContactSpec c;
    c.mu = r.num(n, path, "mu", &d.mu);
    c.adhesion_nN = r.num(n, path, "adhesion_nN", &d.adhesion_nN);
    if (with_area) {
        c.shear_strength_MPa = r.num(n, path, "shear_strength_MPa", &d.shear_strength_MPa);
        c.contact_area_nm2 = r.num(n, path, "contact_area_nm2", &d.contact_area_nm2);
    }
    return c;
}

}  // namespace afm::scene_detail
