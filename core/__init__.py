"""tissuebench.core: the bottom floor, which every other folder may import and which imports
none of them: the one bad-input exception (`errors.py`), the signal handling
(`interrupt.py`), the fingerprint of a set of inputs (`fingerprint.py`) and the other ranks'
sleeping wait for rank 0 (`waiting.py`)."""
