"""Checks that the files the project points people and machines at exist and agree."""

import re
import shutil
import subprocess
import unittest
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]


class RepoTest(unittest.TestCase):
    def test_design_card_layout(self):
        for entry in ["CMakeLists.txt", "lcmtypes", "services", "common", "cuda", "configs", "scripts", "tests", "docker"]:
            self.assertTrue((REPO / entry).exists(), entry)

    def test_dockerfile_references_existing_files(self):
        dockerfile = (REPO / "docker/Dockerfile").read_text()
        copies = re.findall(r"^COPY (?!--from)(\S+) ", dockerfile, re.M)
        self.assertTrue(copies)
        for src in copies:
            self.assertTrue((REPO / src).exists(), f"Dockerfile copies missing {src}")
        entry = re.search(r'ENTRYPOINT \["([^"]+)"', dockerfile).group(1)
        self.assertTrue(entry.startswith("/mfot/"))
        self.assertTrue((REPO / entry[len("/mfot/"):]).is_file(), entry)
        script = (REPO / "docker/entrypoint.sh").read_text()
        for ref in re.findall(r"(scripts/\S+|configs/\S+)", script):
            self.assertTrue((REPO / ref).exists(), f"entrypoint references missing {ref}")

    def test_ci_runs_the_readme_test_command(self):
        readme = (REPO / "README.md").read_text()
        commands = re.search(r"```sh\n(.*?)```", readme, re.S).group(1).strip().splitlines()
        self.assertEqual(len(commands), 2, "the README opens with exactly two commands")
        test_cmd = commands[1].split("#")[0].strip()
        ci = (REPO / ".ci/run").read_text()
        self.assertIn(f"exec {test_cmd}", ci)
        for cmd in commands:
            self.assertTrue((REPO / cmd.split()[0]).is_file(), cmd)

    def test_every_config_key_is_documented(self):
        for line in (REPO / "configs/default.yaml").read_text().splitlines():
            if re.match(r"^\s+\w+:\s*\S", line) and not line.strip().startswith("#"):
                self.assertIn("#", line, f"undocumented config value: {line.strip()}")

    def test_cpp_files_are_formatted(self):
        # Every C++/CUDA file in git follows .clang-format.
        clang_format = shutil.which("clang-format")
        self.assertIsNotNone(clang_format, "clang-format not found: scripts/setup installs it")
        files = subprocess.run(["git", "ls-files", "*.cpp", "*.hpp", "*.h", "*.cu", "*.cuh"], cwd=REPO,
                               capture_output=True, text=True, check=True).stdout.split()
        self.assertTrue(files)
        result = subprocess.run([clang_format, "--dry-run", "--Werror", *files], cwd=REPO, capture_output=True,
                                text=True)
        self.assertEqual(result.returncode, 0, f"not formatted (run clang-format -i on them):\n{result.stderr[:4000]}")

    def test_every_source_is_listed_in_its_cmake_file(self):
        # Sources are listed by name (no globbing): a file left out would silently not be built or tested.
        places = {"common/src": "common/CMakeLists.txt", "common/src/sim": "common/CMakeLists.txt",
                  "services/common/src": "services/CMakeLists.txt", "cuda/src": "cuda/CMakeLists.txt",
                  "tests/core": "tests/CMakeLists.txt", "tests/discovery": "tests/CMakeLists.txt",
                  "tests/sim": "tests/CMakeLists.txt", "tests/cuda": "tests/CMakeLists.txt",
                  "tests/services": "tests/services/CMakeLists.txt", "lcmtypes": "lcmtypes/CMakeLists.txt"}
        for folder, cmake in places.items():
            listed = (REPO / cmake).read_text()
            for source in sorted((REPO / folder).iterdir()):
                if source.suffix in (".cpp", ".cu", ".lcm"):
                    self.assertRegex(listed, rf"(^|[\s/]){re.escape(source.name)}\s", f"{folder}/{source.name} not in {cmake}")


if __name__ == "__main__":
    unittest.main()
