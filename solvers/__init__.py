"""tissuebench.solvers"""
