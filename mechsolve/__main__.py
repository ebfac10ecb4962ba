from mechsolve.cli.main import entry

entry()
