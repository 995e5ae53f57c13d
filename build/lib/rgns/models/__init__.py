"""The GNS shipped with rgns: weights, card and learning curve (see card.md)."""
