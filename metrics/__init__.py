"""tissuebench.metrics"""
