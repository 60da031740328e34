"""Emulated EPL skin patches as Controlled Nodes (EPSG DS 301 V1.4.0) for a real MN.

- ``od``: the object dictionary; ``nmt``: the CN state machine; ``sdo_server``: SDO over ASnd;
- ``cn``: one node (its data link layer and prepared frames); ``skin``: N nodes on one link;
- ``live``: the receive loop on a raw socket (``skinframes serve epl``).
"""
