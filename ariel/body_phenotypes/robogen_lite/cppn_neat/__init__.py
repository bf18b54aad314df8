"""CPPN-NEAT body genomes (upstream's ``robogen_lite.cppn_neat``): `Genome` (node and connection
genes, NEAT mutation and crossover, activation), `IdManager` (innovation and node ids) and the
``cppn`` body encoder (`ariel.body_phenotypes.robogen_lite.cppn_encoder`). The genome is
decoded into a body by ``decoders.cppn_best_first.MorphologyDecoderBestFirst``."""
