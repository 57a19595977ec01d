"""Speed/accuracy study of an example scene (see eigenmpm/study.py for the knobs, the error
measures and the outputs)::

    yade -n -x examples/study.py SCENE knob=v1,v2,... [--out DIR] [--reference finest|closed-form|RUN_DIR]
        [--cost cpu|loop|psteps] [--quick] [--rerun] [--timeout S] [--dry-run]

e.g. ``yade -n -x examples/study.py vibrating_bar h=100,50,25 shape=linear,uGIMP``.
"""
import sys

from eigenmpm import study

if __name__ == "__main__":
    study.main(sys.argv[1:])
