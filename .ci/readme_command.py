"""Print the README's Nth quick-start command (1-based), so CI runs it verbatim."""

import re
import sys
from pathlib import Path

readme = Path(__file__).resolve().parent.parent / "README.md"
section = readme.read_text().split("## Quick start", 1)[1].split("\n## ", 1)[0]
blocks = re.findall(r"```bash\n(.*?)\n```", section, flags=re.DOTALL)
print(blocks[int(sys.argv[1]) - 1].strip())
