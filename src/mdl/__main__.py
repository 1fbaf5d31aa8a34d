from mdl.cli import run

run()
