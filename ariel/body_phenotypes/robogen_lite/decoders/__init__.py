"""Decoders from genotype outputs (probability matrices) to robot graphs."""

from ariel.body_phenotypes.robogen_lite.decoders.hi_prob_decoding import HighProbabilityDecoder

__all__ = ["HighProbabilityDecoder"]
