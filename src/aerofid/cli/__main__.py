from aerofid.cli import main

main()
