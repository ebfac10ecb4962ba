from mechsolve.cli.main import main

main()
