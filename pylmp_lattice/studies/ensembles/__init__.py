"""Ensembles: replicas of random chains (thermal motion, disorder), their means with standard
errors: thermal."""
