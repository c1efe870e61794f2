import sys

from .cli import main

if __name__ == "__main__":  # `python -m cortex_ti`; importing the module (the API reference does) runs nothing
    sys.exit(main())
