"""tissuebench.workflows"""
