"""Physics simulations behind dmprs's built-in adapters. Each module imports its own physics
engine; nothing here is imported by ``import dmprs``.
"""
