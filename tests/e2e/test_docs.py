"""The docs say what the code does (issue 33): README.md and docs/*.md link
only to files that exist; docs/scenes.md lists exactly the scene keys the
validator accepts; the commands table of docs/commands.md names every
command `./afm --help` lists; the README is read in five minutes (at most
1,200 words, issue 45); docs/layout.md names folders that exist, and its
move map says which moves are made.

The format these tests read (docs/scenes.md says it too):

- docs/scenes.md, section "## Keys" (from that heading to the next "## "
  heading): every table row whose first cell is one key in backticks is a
  key, written as its dotted path from the scene's top level; an element of
  a list of mappings is written `[]`:

      | `sample.wire.segments` | ... |
      | `objects.particles[].radius_nm` | ... |

  A key that holds a mapping or a list of mappings is a row too
  (`sample.wire`, `objects.particles`). Rows elsewhere are not keys.
- docs/scenes.md, section "## Effects": every table row whose first cell is
  one name in backticks is an effect.
- docs/commands.md, section "# Commands": the commands are the backticked
  spans of the table's first column; `\\|` in a span is an alternative
  (`./afm bench firmware\\|sim` is `bench firmware` and `bench sim`).
- README.md: its words are what `wc -w` counts (runs of non-blank characters).
- docs/layout.md, section "## Folders": the first cell of each row is one
  folder in backticks, from the checkout's top; section "## Planned moves":
  each row is | from | to | status | why |, the backticked paths of "from"
  are files or folders of the checkout, the status `planned` or `done`.

The accepted keys come from the validator itself (scene/scene.cpp,
only_keys): a scene with a bogus key in a mapping is refused with
"FILE: PATH.bogus: unknown key (known here: a, b, c)". Starting at the top
level, each known key is tried as a mapping ({bogus: 1}) and as a list of
mappings ([{bogus: 1}]); where the validator answers "unknown key" at
KEY.bogus or KEY[0].bogus, that key is a mapping (or a list of them) and is
walked in turn. Each probe starts from a scene of scenes/ that has a valid
value at the probed path (else from scenes/lithography.yaml, whose
lithography effect lets operator.plan.cuts be read), so that the value's
required keys are there before the validator reaches a nested one."""
import concurrent.futures
import copy
import glob
import os
import re
import shutil
import subprocess
import unittest

import yaml

import e2e_support

SRC = e2e_support.SRC
BOGUS = "zz_not_a_key"
KEY_ROW = re.compile(r"^\|\s*`([A-Za-z_][A-Za-z0-9_.\[\]]*)`\s*\|")


def section(text, heading):
    """The lines of a markdown section: from `heading` to the next heading of
    the same level."""
    level = heading.split(" ")[0]
    out, inside = [], False
    for line in text.splitlines():
        if line.strip() == heading:
            inside = True
            continue
        if inside and re.match(r"^#{1,%d} " % len(level), line):
            break
        if inside:
            out.append(line)
    return out


def doc_rows(path, heading):
    with open(path) as f:
        lines = section(f.read(), heading)
    return [m.group(1) for m in map(KEY_ROW.match, lines) if m]


# ---- the validator's keys ---------------------------------------------------

def scene_files():
    return sorted(glob.glob(os.path.join(SRC, "scenes", "*.yaml")) + glob.glob(os.path.join(SRC, "scenes", "paper", "*.yaml")))


def load_standalone(path):
    """A scene as the launcher resolves it (afm_launch --resolved: its includes
    merged, its file names absolute), so that it validates from any folder."""
    p = subprocess.run([e2e_support.LAUNCH, "--resolved", "--quiet", "--scene", path],
                       capture_output=True, text=True, timeout=60)
    if p.returncode:
        raise AssertionError(f"{path}: afm_launch --resolved: exit {p.returncode}: {p.stderr.strip()}")
    return yaml.safe_load(p.stdout)


def get(doc, path):
    """The value at path (a tuple of keys, 0 for a list's first element), or None."""
    node = doc
    for p in path:
        if p == 0:
            if not isinstance(node, list) or not node:
                return None
            node = node[0]
        elif isinstance(node, dict) and p in node:
            node = node[p]
        else:
            return None
    return node


def put(doc, path, value):
    """Sets the value at path, making the mappings and lists on the way."""
    node = doc
    for i, p in enumerate(path[:-1]):
        nxt = path[i + 1]
        want = list if nxt == 0 else dict
        if p == 0:
            if not node:
                node.append(want())
            if not isinstance(node[0], want):
                node[0] = want()
            node = node[0]
        else:
            if not isinstance(node.get(p), want) or (want is list and not node[p]):
                node[p] = want()
            node = node[p]
    last = path[-1]
    if last == 0:
        if node:
            node[0] = value
        else:
            node.append(value)
    else:
        node[last] = value


def dotted(path):
    s = ""
    for p in path:
        s += "[]" if p == 0 else ("." + p if s else p)
    return s


def shown(path):
    """The path as the validator names it (list elements as [0])."""
    return dotted(path).replace("[]", "[0]")


class Validator:
    def __init__(self):
        self.bases = [(f, load_standalone(f)) for f in scene_files()]
        fallback = os.path.join(SRC, "scenes", "lithography.yaml")
        self.fallback = load_standalone(fallback)
        self.dir = e2e_support.tmpdir("keys")
        self.count = 0

    def base_for(self, path):
        for _, doc in self.bases:
            if isinstance(get(doc, path), dict):
                return copy.deepcopy(doc)
        return copy.deepcopy(self.fallback)

    def check(self, doc):
        """Runs afm_launch --check on a scene; returns its message."""
        self.count += 1
        path = os.path.join(self.dir, f"probe{self.count}.yaml")
        with open(path, "w") as f:
            yaml.safe_dump(doc, f, sort_keys=False)
        p = subprocess.run([e2e_support.LAUNCH, "--check", "--scene", path], capture_output=True, text=True, timeout=60)
        return p.returncode, p.stdout + p.stderr

    def known_at(self, path):
        """The keys the validator knows in the mapping at path (a tuple), or
        None if the value there is not read as a mapping."""
        doc = self.base_for(path)
        value = get(doc, path)
        value = dict(value) if isinstance(value, dict) else {}
        value[BOGUS] = 1
        if path:
            put(doc, path, value)
        else:
            doc = value
        code, msg = self.check(doc)
        where = (shown(path) + "." if path else "") + BOGUS
        m = re.search(re.escape(where) + r": unknown key \(known here: ([^)]*)\)", msg)
        if not m:
            return None
        if code == 0:
            raise AssertionError(f"a bogus key at {where} was accepted")
        return [k.strip() for k in m.group(1).split(",")]

    def all_keys(self):
        """Every key path the validator accepts, dotted, lists as []."""
        keys = set()
        todo = [()]
        seen = set()
        with concurrent.futures.ThreadPoolExecutor(max_workers=8) as pool:
            while todo:
                found = list(pool.map(self.known_at, todo))
                nxt = []
                for path, known in zip(todo, found):
                    if known is None:
                        continue
                    for k in known:
                        child = path + (k,)
                        keys.add(dotted(child))
                        for sub in (child, child + (0,)):
                            if sub not in seen:
                                seen.add(sub)
                                nxt.append(sub)
                todo = nxt
        return keys

    def known_effects(self):
        doc = copy.deepcopy(self.fallback)
        doc["effects"] = [BOGUS]
        _, msg = self.check(doc)
        m = re.search(r"unknown effect '%s' \(known: ([^)]*)\)" % BOGUS, msg)
        if not m:
            raise AssertionError("the validator did not name the known effects: " + msg)
        return {k.strip() for k in m.group(1).split(",")}


# ---- ./afm --help's commands --------------------------------------------------

def commands_in(span):
    """The commands a usage line or a table cell's span names: the words after
    ./afm up to the first argument (an upper-case word, [, -, ...); a word
    with | stands for each of its alternatives."""
    words = span.replace("\\|", "|").split()
    if not words or words[0] != "./afm" or len(words) < 2:
        return set()
    cmd = [words[1]]
    for w in words[2:]:
        if not re.fullmatch(r"[a-z][a-z0-9|]*", w):
            break
        cmd.append(w)
    out = {""}
    for w in cmd:
        out = {(o + " " + alt).strip() for o in out for alt in w.split("|")}
    return out


def help_commands():
    p = subprocess.run([os.path.join(SRC, "afm"), "--help"], capture_output=True, text=True, timeout=60)
    assert p.returncode == 0, p.stderr
    cmds = set()
    for line in p.stdout.splitlines():
        if line.startswith("  ./afm "):
            cmds |= commands_in(re.split(r"\s{2,}", line.strip())[0])   # the description follows 2 spaces
    return cmds


def table_commands(text):
    cmds = set()
    for line in section(text, "# Commands"):
        if not line.startswith("|"):
            continue
        cells = re.split(r"(?<!\\)\|", line)
        if len(cells) < 3:
            continue
        for span in re.findall(r"`([^`]*)`", cells[1]):
            cmds |= commands_in(span)
    return cmds


# ---- the tests ----------------------------------------------------------------

def doc_files():
    return [os.path.join(SRC, "README.md")] + sorted(glob.glob(os.path.join(SRC, "docs", "*.md")))


class Links(unittest.TestCase):
    def test_every_relative_link_resolves(self):
        files = doc_files()
        self.assertGreater(len(files), 5, "README.md and docs/*.md")
        checked = 0
        for path in files:
            text = open(path).read()
            text = re.sub(r"```.*?```", "", text, flags=re.S)      # code blocks hold no links
            for target in re.findall(r"\]\(([^)\s]+)(?:\s+\"[^\"]*\")?\)", text):
                if re.match(r"^[a-z][a-z0-9+.-]*:", target) or target.startswith("#"):
                    continue                                          # a URL, or an anchor on this page
                file_part = target.split("#", 1)[0]
                resolved = os.path.normpath(os.path.join(os.path.dirname(path), file_part))
                self.assertTrue(os.path.exists(resolved), f"{os.path.relpath(path, SRC)}: link {target!r} resolves to nothing")
                self.assertTrue(resolved.startswith(SRC + os.sep), f"{os.path.relpath(path, SRC)}: link {target!r} leaves the checkout")
                checked += 1
        self.assertGreater(checked, 10)

    def test_no_reference_outside_the_checkout(self):
        for path in doc_files():
            self.assertNotIn("../shared", open(path).read(), os.path.relpath(path, SRC))


class SceneKeys(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.validator = Validator()
        cls.accepted = cls.validator.all_keys()
        cls.doc = os.path.join(SRC, "docs", "scenes.md")

    def test_the_walk_found_the_nested_keys(self):
        # the walk itself must work, or the comparison below means nothing
        for k in ("name", "sample.wire.segments", "objects.particles[].radius_nm", "operator.plan.cuts[].load_nN",
                  "operator.haptic.force_gain_N_per_nN", "objects.targets.text"):
            self.assertIn(k, self.accepted)

    def test_docs_list_exactly_the_accepted_keys(self):
        rows = doc_rows(self.doc, "## Keys")
        documented = set(rows)
        self.assertEqual(len(rows), len(documented), "a key listed twice in docs/scenes.md")
        missing = sorted(self.accepted - documented)
        unknown = sorted(documented - self.accepted)
        self.assertEqual(missing, [], "keys the validator accepts that docs/scenes.md does not list")
        self.assertEqual(unknown, [], "keys docs/scenes.md lists that the validator refuses")

    def test_docs_list_exactly_the_effects(self):
        effects = self.validator.known_effects()
        documented = set(doc_rows(self.doc, "## Effects"))
        self.assertEqual(sorted(effects - documented), [], "effects docs/scenes.md does not list")
        self.assertEqual(sorted(documented - effects), [], "effects docs/scenes.md lists that the validator refuses")

    @classmethod
    def tearDownClass(cls):
        e2e_support.cleanup(cls.validator.dir)


class Commands(unittest.TestCase):
    def test_the_commands_table_names_every_command_of_help(self):
        listed = help_commands()
        for c in ("demo", "test", "run", "bench bus", "calib tilted", "--help"):
            self.assertIn(c, listed, "the usage text's parse")
        table = table_commands(open(os.path.join(SRC, "docs", "commands.md")).read())
        self.assertIn("bench pil", table, "the table's parse")
        self.assertEqual(sorted(listed - table), [], "commands ./afm --help lists that docs/commands.md's table does not")

    def test_one_help_file_per_command_read_by_afm_and_the_program(self):
        # docs/help/COMMAND.txt is what ./afm COMMAND --help prints (before
        # anything is built) and what the command's own program prints at
        # the head of its --help; ./afm --help is afm.txt with every
        # "@COMMAND" line replaced by that file
        afm = os.path.join(SRC, "afm")
        help_dir = os.path.join(SRC, "docs", "help")
        files = sorted(f[:-4] for f in os.listdir(help_dir) if f.endswith(".txt") and f != "afm.txt")
        overview = open(os.path.join(help_dir, "afm.txt")).read()
        self.assertEqual(sorted(l[1:] for l in overview.splitlines() if l.startswith("@")), files,
                         "afm.txt names each command's file once")
        whole = subprocess.run([afm, "--help"], capture_output=True, text=True, timeout=60).stdout
        for c in files:
            text = open(os.path.join(help_dir, c + ".txt")).read().rstrip("\n")
            self.assertIn(text, whole, c)
        for c in ("demo", "test", "run", "check", "view", "spy", "setup", "build"):
            p = subprocess.run([afm, c, "--help"], capture_output=True, text=True, timeout=60)
            self.assertEqual(p.returncode, 0, (c, p.stderr))
            self.assertEqual(p.stdout.rstrip("\n"), open(os.path.join(help_dir, c + ".txt")).read().rstrip("\n"), c)
        # the programs: the Python commands' argparse and afm_replay read the same file
        progs = {"sweep": [afm, "sweep", "--help"], "paper": [afm, "paper", "--help"], "export": [afm, "export", "--help"],
                 "faults": [afm, "faults", "--help"], "fuzz": [afm, "fuzz", "--help"], "replay": [e2e_support.paths.REPLAY, "--help"]}
        for c, argv in progs.items():
            p = subprocess.run(argv, capture_output=True, text=True, timeout=120)
            self.assertEqual(p.returncode, 0, (c, p.stderr))
            self.assertIn(open(os.path.join(help_dir, c + ".txt")).read().rstrip("\n"), p.stdout, c)

    def test_readme_keeps_the_contract(self):
        readme = open(os.path.join(SRC, "README.md")).read()
        self.assertIn("./afm demo", readme)
        self.assertIn("./afm test", readme)


README_MAX_WORDS = 1200   # issue 45: a newcomer reads it in five minutes


class Readme(unittest.TestCase):
    def test_the_readme_is_at_most_1200_words(self):
        words = len(open(os.path.join(SRC, "README.md")).read().split())
        self.assertGreater(words, 300, "the README says what the bench is, the two commands, what a run writes")
        self.assertLessEqual(words, README_MAX_WORDS,
                             f"README.md: {words} words; move the detail into docs/ (docs/layout.md lists the pages)")

    def test_it_links_to_the_pages_a_newcomer_needs(self):
        readme = open(os.path.join(SRC, "README.md")).read()
        for page in ("docs/commands.md", "docs/design.md", "docs/layout.md"):
            self.assertIn(f"]({page}", readme, page)


def layout_rows(heading):
    """The rows of a table in docs/layout.md's section `heading`, as lists of cells."""
    with open(os.path.join(SRC, "docs", "layout.md")) as f:
        lines = section(f.read(), heading)
    rows = [[c.strip() for c in l.strip().strip("|").split("|")] for l in lines if l.startswith("| ")]
    return [r for r in rows if not set(r[0]) <= set("- ")][1:]   # the header row and the rule left out


class Layout(unittest.TestCase):
    def test_every_folder_named_exists(self):
        rows = layout_rows("## Folders")
        self.assertGreater(len(rows), 15, "the folder table's parse")
        for row in rows:
            m = re.fullmatch(r"`([^`]+/)`", row[0])
            self.assertIsNotNone(m, f"docs/layout.md: a folder row's first cell is one folder in backticks: {row[0]!r}")
            self.assertTrue(os.path.isdir(os.path.join(SRC, m.group(1))), f"docs/layout.md names {m.group(1)}, not a folder")
        named = {re.fullmatch(r"`([^`]+)/`", r[0]).group(1) for r in rows}
        if not shutil.which("git") or not os.path.exists(os.path.join(SRC, ".git")):
            return   # a tree got as an archive: no list of tracked files to hold the table to
        tracked = subprocess.run(["git", "-C", SRC, "ls-files"], capture_output=True, text=True, timeout=60)
        if tracked.returncode == 0:   # a checkout: every top-level folder of it has its row
            tops = {p.split("/")[0] for p in tracked.stdout.splitlines() if "/" in p and not p.startswith(".")}
            self.assertEqual(sorted(tops - named), [], "top-level folders docs/layout.md does not name")

    def test_the_move_map_says_which_moves_are_made(self):
        rows = layout_rows("## Planned moves")
        self.assertGreater(len(rows), 5, "the move map's parse")
        for row in rows:
            self.assertEqual(len(row), 4, f"docs/layout.md: a move is | from | to | status | why |: {row}")
            sources = re.findall(r"`([^`]+)`", row[0])
            self.assertTrue(sources, f"docs/layout.md: a move names its source in backticks: {row[0]!r}")
            self.assertIn(row[2], ("planned", "done"), row)
            if row[2] == "planned":
                for src in sources:
                    self.assertTrue(os.path.exists(os.path.join(SRC, src)),
                                    f"docs/layout.md: {src} is gone: the move is made, mark it done (and its target)")
            else:
                for dst in re.findall(r"`([^`]+)`", row[1]):
                    self.assertTrue(os.path.exists(os.path.join(SRC, dst)), f"docs/layout.md: a done move's {dst} is not there")


if __name__ == "__main__":
    e2e_support.main()
