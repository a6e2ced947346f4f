"""Studies of the literature: chains with exact or classical results (harmonic, toda, hugoniot)."""
