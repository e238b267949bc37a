"""Regenerate the built-in world files, or write a generated one: ``python -m sim.arenas [DIRECTORY]
[--generated SEED [--version N]]`` (default directory: ./worlds)."""

import argparse
from pathlib import Path

from . import BUILTIN_BUILDERS, GENERATOR_VERSION, GENERATOR_VERSIONS, generated, write_world

parser = argparse.ArgumentParser(prog="python -m sim.arenas", description=__doc__.split(":")[0] + ".")
parser.add_argument("directory", nargs="?", type=Path, default=Path("worlds"),
                    help="where to write NAME.xml and NAME.routes.json (default: worlds)")
parser.add_argument("--generated", type=int, metavar="SEED",
                    help="write the generated world genN:SEED (as genN_SEED.xml) instead of the built-in ones")
parser.add_argument("--version", type=int, choices=GENERATOR_VERSIONS, default=GENERATOR_VERSION,
                    help=f"the generator's version for --generated (default: {GENERATOR_VERSION})")
args = parser.parse_args()
if args.generated is not None and args.generated < 0:
    parser.error(f"--generated {args.generated}: the seed must be a non-negative integer")
sources = ([generated(args.generated, args.version)] if args.generated is not None
           else [build() for build in BUILTIN_BUILDERS.values()])
for source in sources:
    print(write_world(source, args.directory))
