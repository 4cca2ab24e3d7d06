"""tissuebench.meshes"""
