"""End-to-end training: IEN -> spot -> image formation through the stored transport -> NLOS network."""
