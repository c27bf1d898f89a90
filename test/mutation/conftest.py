# check.py plants bugs in a copy of the package and runs the tests against each: slow, and
# not a test module. Run it by hand (README.md here).
collect_ignore = ["check.py"]
