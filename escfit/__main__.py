"""``python -m escfit ...``: the same command line as ``escfit ...`` (for environments where the
console script is not on the PATH)."""

from escfit.cli.main import main

if __name__ == "__main__":
    main()
