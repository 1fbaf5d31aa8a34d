from mdl.cli import main

main()
