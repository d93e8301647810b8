"""The firmware's wire and lithography models on the bench (issue 3's
"the firmware node uses all of them"): a rigid silver wire pushed in a
zigzag, and a trench inscribed on polycarbonate. The firmware's closed forms
(fw_wire: static point, k(l) f L, first-order rotation; fw_litho: depth law)
are checked against the simulator's own physics (least friction power over
K friction points; material removal), from the recorded log."""
import copy
import math
import unittest

import e2e_support
from analysis import afmlog


CHANNELS = {"FW_STATE", "SIM_TRUTH"}


def ends(w):
    return (w.x_nm[0], w.y_nm[0]), (w.x_nm[-1], w.y_nm[-1])


class WireZigzag(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.out, cls.code, cls.err, cls.rj, cls.log = e2e_support.run_and_load("wire_push.yaml", "wire", CHANNELS)

    @classmethod
    def tearDownClass(cls):
        e2e_support.cleanup(cls.out)

    def test_firmware_rod_matches_the_simulated_rod_between_pushes(self):
        # Between pushes (neither model in contact for 50 blocks) the two
        # rods must agree within 5 nm at both ends. During a push the
        # firmware's first-order update may lead or lag the simulator's
        # quasi-static solve; that transient is printed, not bounded.
        self.assertEqual(self.code, 0, self.err)
        fw = afmlog.whole_by_seq(self.log["FW_STATE"], lambda m: m.objects)
        truth = afmlog.whole_by_seq(self.log["SIM_TRUTH"], lambda m: m.objects)
        def err(seq):
            return max(math.hypot(a[0] - b[0], a[1] - b[1])
                       for a, b in zip(ends(fw[seq].wires[0]), ends(truth[seq].wires[0])))
        quiet, at_rest, worst_any = 0, [], 0.0
        for seq in sorted(fw):
            busy = fw[seq].wires[0].in_contact or truth[seq].wires[0].in_contact
            quiet = 0 if busy else quiet + 1
            worst_any = max(worst_any, err(seq))
            if quiet >= 50:
                at_rest.append(err(seq))
        first, last = ends(truth[min(truth)].wires[0]), ends(truth[max(truth)].wires[0])
        moved = max(math.hypot(a[0] - b[0], a[1] - b[1]) for a, b in zip(first, last))
        print(f"wire ends: at rest worst {max(at_rest):.2f} nm over {len(at_rest)} blocks; during pushes worst "
              f"{worst_any:.2f} nm; the ends moved up to {moved:.0f} nm")
        self.assertGreater(moved, 100.0, "the zigzag must move the wire")
        self.assertGreater(len(at_rest), 1000)
        self.assertLess(max(at_rest), 5.0)
        self.assertLess(err(max(fw)), 5.0)


    def test_objects_recorded_out_of_order_read_as_in_order(self):
        # The bus may reorder two adjacent FW_STATE datagrams (./afm faults,
        # net:kernel): the later block's changes come before its base. Read
        # back, the objects of every block are those read in order; a block
        # whose message is lost leaves the blocks after it unknown until the
        # next complete one.
        msgs = self.log["FW_STATE"]
        pairs = [i for i in range(1, len(msgs) - 1)
                 if not msgs[i].objects.complete and not msgs[i + 1].objects.complete
                 and msgs[i + 1].objects.base_seq == msgs[i].objects.seq and msgs[i].objects.n_wires > 0]
        self.assertGreater(len(pairs), 10, "the zigzag must move the wire in successive blocks")
        swapped = list(msgs)
        for i in pairs[::7]:
            swapped[i], swapped[i + 1] = swapped[i + 1], swapped[i]
        def coords(w):
            return ([(p.x_nm, p.y_nm) for p in w.particles], [(tuple(v.x_nm), tuple(v.y_nm)) for v in w.wires])
        ordered = afmlog.whole_by_seq(msgs, lambda m: m.objects)
        reordered = afmlog.whole_by_seq(swapped, lambda m: m.objects)
        self.assertEqual(sorted(ordered), sorted(reordered))
        for seq in ordered:
            self.assertEqual(coords(ordered[seq]), coords(reordered[seq]), f"block {seq}")
        # the first block's complete message recorded after the second's changes
        self.assertTrue(msgs[0].objects.complete and not msgs[1].objects.complete)
        late_first = afmlog.whole_by_seq([msgs[1], msgs[0]] + msgs[2:], lambda m: m.objects)
        self.assertEqual(sorted(ordered), sorted(late_first))
        self.assertEqual(coords(ordered[max(ordered)]), coords(late_first[max(ordered)]))
        # one lost: unknown until the next complete message
        lost = pairs[len(pairs) // 2]
        gone = afmlog.whole_by_seq(msgs[:lost] + msgs[lost + 1:], lambda m: m.objects)
        lost_seq = msgs[lost].objects.seq
        healed = min(m.objects.seq for m in msgs[lost:] if m.objects.complete)
        self.assertNotIn(lost_seq, gone)
        self.assertNotIn(lost_seq + 1, gone)
        self.assertIn(healed, gone)
        self.assertEqual(coords(gone[healed]), coords(ordered[healed]))


    def test_a_change_to_an_object_the_set_lacks_reads_as_a_lost_message(self):
        # afmlog reads objects through the renderer's and the operator's own
        # reader (common/objects_view_c.h): a changes-only message naming a
        # wire the set does not hold is refused, and the blocks after it are
        # unknown until the next complete message, as the renderer has them
        msgs = self.log["FW_STATE"]
        # a changes-only message naming a wire, followed by another
        # changes-only one, with a complete message after them
        last_complete = max(k for k, m in enumerate(msgs) if m.objects.complete)
        i = next(k for k in range(1, last_complete - 1)
                 if not msgs[k].objects.complete and msgs[k].objects.n_wires > 0 and not msgs[k + 1].objects.complete)
        bad = copy.deepcopy(msgs[i])
        bad.objects.wires[0].id = 999
        ordered = afmlog.whole_by_seq(msgs, lambda m: m.objects)
        read = afmlog.whole_by_seq(msgs[:i] + [bad] + msgs[i + 1:], lambda m: m.objects)
        seq = msgs[i].objects.seq
        healed = min(m.objects.seq for m in msgs[i:] if m.objects.complete)
        self.assertTrue(seq - 1 in read, f"block {seq - 1}, before it, unknown")
        self.assertFalse(seq in read, f"block {seq}, naming wire 999, read")
        self.assertFalse(seq + 1 in read, f"block {seq + 1}, after it, read")
        self.assertTrue(healed in read, f"block {healed}, the next complete one, unknown")
        self.assertEqual([w.id for w in read[healed].wires], [w.id for w in ordered[healed].wires])
        self.assertTrue(all(w.complete for w in read.values()))


class Trench(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.out, cls.code, cls.err, cls.rj, cls.log = e2e_support.run_and_load("lithography.yaml", "litho", CHANNELS)

    @classmethod
    def tearDownClass(cls):
        e2e_support.cleanup(cls.out)

    def test_firmware_trench_matches_the_simulated_cut(self):
        self.assertEqual(self.code, 0, self.err)
        fw = self.log["FW_STATE"][-1].objects
        truth = self.log["SIM_TRUTH"][-1].objects
        self.assertEqual(fw.n_trenches, 1)
        self.assertEqual(truth.n_trenches, 1)
        f, t = fw.trenches[0], truth.trenches[0]
        mid_f, mid_t = f.n // 2, t.n // 2
        print(f"trench: firmware depth {f.depth_nm[mid_f]:.3f} nm width {f.width_nm[mid_f]:.3f} nm; "
              f"simulator depth {t.depth_nm[mid_t]:.3f} nm width {t.width_nm[mid_t]:.3f} nm")
        self.assertAlmostEqual(f.depth_nm[mid_f], t.depth_nm[mid_t], delta=0.5)
        self.assertAlmostEqual(f.width_nm[mid_f], t.width_nm[mid_t], delta=0.5)
        # Same path: both run from the first to the last waypoint within 10 nm.
        for (fx, fy), (tx, ty) in (((f.x_nm[0], f.y_nm[0]), (t.x_nm[0], t.y_nm[0])),
                                   ((f.x_nm[-1], f.y_nm[-1]), (t.x_nm[-1], t.y_nm[-1]))):
            self.assertLess(math.hypot(fx - tx, fy - ty), 10.0)


if __name__ == "__main__":
    e2e_support.main()
