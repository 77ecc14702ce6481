"""Checks that the documentation stays what a newcomer needs: a short README, links that resolve, the measured results
rendered from their one machine-readable file, and every equation the code cites restated in docs/method.md."""

import json
import re
import subprocess
import sys
import unittest
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
DOCS = REPO / "docs"
LINK = re.compile(r"(?<!!)\[[^\]]*\]\(([^)\s]+)\)")
# Equation numbers of the thesis's chapters 2-4 as the code cites them: "(3.22)", "equation 3.21", "eqs. 4.1-4.2",
# "(3.22, 3.23)", "equations 2.18 to 2.21".
CITED_IN_PARENS = re.compile(r"\(([234]\.\d{1,2})((?:\s*(?:-|–|,|/|to)\s*[234]\.\d{1,2})*)\)")
CITED_BY_WORD = re.compile(r"\b(?:eqs?\.|equations?)\s*([234]\.\d{1,2})((?:\s*(?:-|–|to)\s*[234]\.\d{1,2})?)", re.I)


def markdown_files():
    return [REPO / "README.md", *sorted(DOCS.glob("*.md"))]


def github_anchor(heading: str) -> str:
    text = re.sub(r"[^\w\- ]", "", heading.strip().lower())
    return text.replace(" ", "-")


def anchors(path: Path) -> set:
    return {github_anchor(m.group(1)) for m in re.finditer(r"^#+ (.+)$", path.read_text(encoding="utf-8"), re.M)}


def equations(first: str, rest: str) -> list:
    """The equation numbers of one citation, a range expanded ("2.18 to 2.21" is 2.18, 2.19, 2.20, 2.21)."""
    numbers = [first, *re.findall(r"[234]\.\d{1,2}", rest)]
    if re.search(r"-|–|to", rest) and len(numbers) == 2:
        (ca, a), (cb, b) = (map(int, n.split(".")) for n in numbers)
        if ca == cb and a < b:
            return [f"{ca}.{k}" for k in range(a, b + 1)]
    return numbers


class DocsTest(unittest.TestCase):
    def test_readme_is_a_guide(self):
        lines = (REPO / "README.md").read_text(encoding="utf-8").count("\n")
        self.assertLessEqual(lines, 400, "README.md is a guide for users: keep it under 400 lines, the rest in docs/")

    def test_license_is_bsd_3_clause(self):
        text = (REPO / "LICENSE").read_text(encoding="utf-8")
        self.assertIn("BSD 3-Clause License", text)
        self.assertIn("Copyright (c) 2026, the mfot authors", text)
        self.assertIn("[LICENSE](LICENSE)", (REPO / "README.md").read_text(encoding="utf-8"))

    def test_relative_links_resolve(self):
        for page in markdown_files():
            for target in LINK.findall(page.read_text(encoding="utf-8")):
                if re.match(r"[a-z]+:", target):
                    continue  # a URL
                path, _, anchor = target.partition("#")
                dest = (page.parent / path).resolve() if path else page
                with self.subTest(page=page.name, link=target):
                    self.assertTrue(dest.exists(), f"{page.relative_to(REPO)} links to missing {target}")
                    if anchor and dest.suffix == ".md":
                        self.assertIn(anchor, anchors(dest), f"{page.relative_to(REPO)}: no heading #{anchor}")

    def test_readme_links_every_doc_and_each_doc_links_back(self):
        readme = (REPO / "README.md").read_text(encoding="utf-8")
        for doc in ["architecture", "method", "departures", "results", "experiment-log"]:
            with self.subTest(doc=doc):
                self.assertIn(f"(docs/{doc}.md)", readme)
                self.assertIn("(../README.md", (DOCS / f"{doc}.md").read_text(encoding="utf-8"))

    def test_results_md_is_what_gen_results_renders(self):
        res = subprocess.run([sys.executable, str(REPO / "scripts/gen-results"), "--check"], capture_output=True,
                             text=True, timeout=60)
        self.assertEqual(res.returncode, 0, res.stdout[-4000:] + res.stderr[-2000:])

    def test_every_result_says_how_when_and_where_it_was_measured(self):
        results = json.loads((DOCS / "results" / "results.json").read_text(encoding="utf-8"))
        for entry in results["entries"] + results["ci_floors"]:
            with self.subTest(entry=entry.get("id")):
                for key in ["id", "name", "command", "date", "machine", "unit"]:
                    self.assertIn(key, entry)
                self.assertTrue(any(k in entry for k in ["table", "text", "values", "output"]), "an entry without figures")
                for machine in entry["machine"] or []:
                    self.assertIn(machine, results["machines"])
        consts = [floor["const"] for floor in results["ci_floors"]]
        self.assertEqual(len(consts), len(set(consts)))

    def test_every_equation_the_code_cites_is_in_method_md(self):
        method = (DOCS / "method.md").read_text(encoding="utf-8")
        files = subprocess.run(["git", "ls-files", "common", "services", "cuda"], cwd=REPO, capture_output=True,
                               text=True, check=True).stdout.split()
        cited = {}
        for name in files:
            if not name.endswith((".hpp", ".cpp", ".h", ".cu", ".cuh")):
                continue
            for number, line in enumerate((REPO / name).read_text(encoding="utf-8", errors="replace").splitlines()):
                comment = line[line.find("//"):] if "//" in line else ""
                for pattern in (CITED_IN_PARENS, CITED_BY_WORD):
                    for m in pattern.finditer(comment):
                        for eq in equations(m.group(1), m.group(2)):
                            cited.setdefault(eq, f"{name}:{number + 1}")
        self.assertGreater(len(cited), 15)
        for eq, where in sorted(cited.items()):
            with self.subTest(equation=eq):
                self.assertIn(f"({eq})", method, f"{where} cites ({eq}), which docs/method.md does not restate")


class RecordTest(unittest.TestCase):
    """scripts/gen-results --record: a benchmark's stdout becomes an entry, with its command, date, machine and commit."""

    def setUp(self):
        import tempfile
        self.tmp = tempfile.TemporaryDirectory()
        self.addCleanup(self.tmp.cleanup)
        self.json = Path(self.tmp.name) / "results.json"
        self.md = Path(self.tmp.name) / "results.md"
        self.json.write_text((DOCS / "results" / "results.json").read_text(encoding="utf-8"), encoding="utf-8")

    def gen(self, *args, command=()):
        return subprocess.run([sys.executable, str(REPO / "scripts" / "gen-results"), "--json", str(self.json),
                               "--md", str(self.md), *args, *(["--", *command] if command else [])],
                              capture_output=True, text=True)

    def record(self, table_row, exit_status=0):
        script = f"print('| seeds | share |'); print('|---|---:|'); print('{table_row}'); raise SystemExit({exit_status})"
        return self.gen("--record", "test-entry", "--name", "A test benchmark", "--group", "accuracy", "--machine",
                        "dev", command=[sys.executable, "-c", script])

    def test_output_is_recorded_and_rendered(self):
        proc = self.record("| 1-5 | 80 % |")
        self.assertEqual(proc.returncode, 0, proc.stderr)
        entries = [e for e in json.loads(self.json.read_text(encoding="utf-8"))["entries"] if e["id"] == "test-entry"]
        self.assertEqual(len(entries), 1)
        self.assertIn("| 1-5 | 80 % |", entries[0]["output"])
        self.assertEqual(entries[0]["machine"], ["dev"])
        self.assertRegex(entries[0]["commit"], r"^[0-9a-f]{12}(-dirty)?$")
        self.assertRegex(entries[0]["date"], r"^\d{4}-\d{2}-\d{2}$")
        self.assertIn("| 1-5 | 80 % |", self.md.read_text(encoding="utf-8"))

    def test_a_second_record_replaces_the_entry_and_keeps_the_exit_status(self):
        self.record("| 1-5 | 80 % |")
        proc = self.record("| 1-5 | 90 % |", exit_status=1)
        self.assertEqual(proc.returncode, 1)
        entries = [e for e in json.loads(self.json.read_text(encoding="utf-8"))["entries"] if e["id"] == "test-entry"]
        self.assertEqual(len(entries), 1)
        self.assertNotIn("80 %", entries[0]["output"])
        self.assertEqual(entries[0]["exit_status"], 1)
        self.assertIn("exit status 1", self.md.read_text(encoding="utf-8"))

    def test_an_unknown_group_or_machine_is_refused_by_name(self):
        before = self.json.read_text(encoding="utf-8")
        proc = self.gen("--record", "x", "--name", "x", "--group", "nonsense", "--machine", "dev",
                        command=[sys.executable, "-c", "print(1)"])
        self.assertNotEqual(proc.returncode, 0)
        self.assertIn("nonsense", proc.stderr)
        proc = self.gen("--record", "x", "--name", "x", "--group", "accuracy", "--machine", "toaster",
                        command=[sys.executable, "-c", "print(1)"])
        self.assertIn("toaster", proc.stderr)
        self.assertEqual(self.json.read_text(encoding="utf-8"), before)


if __name__ == "__main__":
    unittest.main()
