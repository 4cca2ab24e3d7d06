"""The needle as contact (SPEC section 12): the Hertz check, and the contact cases' records and
figures."""
