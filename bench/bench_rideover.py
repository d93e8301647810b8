"""./afm bench rideover: the card's ride-over judgement near eq. 30's dF on
the lift-off scenes (analysis/rideover.py): per scene, whether the truth
rode over, the blocks the card flagged RIDE-OVER and the rod's true move
during them; the two goals and a verdict (exit 1 when one is missed)."""
import sys

from analysis import rideover

if __name__ == "__main__":
    sys.exit(rideover.main(sys.argv[1:]))
