from porosense._console import run

run()
